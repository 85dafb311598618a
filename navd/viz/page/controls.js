// What the operator does: on the map, tap for a goal, drag for the initial pose (confirmed
// on a touch screen), the wheel
// or two fingers (pinch, pan) to zoom and move; the joystick to drive by hand (held, it drives at 10 Hz; let go, one stop and
// silence: the daemon's deadman); cancel, fit, and the token.
import { pointer, state, view } from "./model.js";
import { fit, requestDraw, screenToMap } from "./picture.js";
import { say } from "./panel.js";
import { command } from "./stream.js";

const DRAG_PX = 12;          // a press that moves less than this is a tap (a goal)
const TELEOP_PERIOD_MS = 100; // joystick commands go out at 10 Hz (the daemon's deadman: 0.5 s)

const canvas = document.getElementById("map");

function onMap(event) {
  const r = canvas.getBoundingClientRect();
  return [event.clientX - r.left, event.clientY - r.top];
}

// Pointers down on the map now (id -> [x, y] px). Two at once are a pinch or a pan: it moves
// the view and sends nothing, not even when one finger lifts before the other.
const touching = new Map();

export function listenToTheMap() {
  canvas.addEventListener("pointerdown", (event) => {
    canvas.setPointerCapture(event.pointerId);
    const [x, y] = onMap(event);
    touching.set(event.pointerId, [x, y]);
    if (touching.size === 1 && !pointer.gesture) {
      pointer.press = { x0: x, y0: y, x, y, dragging: false };
    } else {
      pointer.press = null; // a second finger: no goal, no pose from this touch
      pointer.gesture = true;
    }
    requestDraw();
  });
  canvas.addEventListener("pointermove", (event) => {
    if (!touching.has(event.pointerId)) return;
    const now = onMap(event);
    if (pointer.gesture) {
      pinch(touching.get(event.pointerId), now, event.pointerId);
      touching.set(event.pointerId, now);
      return;
    }
    touching.set(event.pointerId, now);
    const press = pointer.press;
    if (!press) return;
    [press.x, press.y] = now;
    press.dragging = press.dragging || Math.hypot(press.x - press.x0, press.y - press.y0) > DRAG_PX;
    requestDraw();
  });
  canvas.addEventListener("pointerup", (event) => {
    touching.delete(event.pointerId);
    const press = pointer.press;
    pointer.press = null;
    if (touching.size === 0) pointer.gesture = false;
    if (!press) { requestDraw(); return; }
    const [x, y] = screenToMap(press.x0, press.y0);
    if (press.dragging) {
      const yaw = Math.atan2(-(press.y - press.y0), press.x - press.x0);
      // a finger slips more easily than a mouse: on a touch screen the pose is confirmed
      const where = `(${x.toFixed(2)}, ${y.toFixed(2)})`;
      if (event.pointerType === "touch" &&
          !window.confirm(`Set the robot's pose to ${where}, facing the way you dragged?`)) {
        say("pose not sent");
      } else {
        command({ type: "initial_pose", x, y, yaw });
        say(`initial pose ${where} sent`);
      }
    } else {
      command({ type: "goal", x, y });
      say(`goal (${x.toFixed(2)}, ${y.toFixed(2)}) sent`);
    }
    requestDraw();
  });
  canvas.addEventListener("pointercancel", (event) => {
    touching.delete(event.pointerId);
    pointer.press = null;
    if (touching.size === 0) pointer.gesture = false;
    requestDraw();
  });
  canvas.addEventListener("wheel", (event) => {
    event.preventDefault();
    const [px, py] = onMap(event);
    zoomAbout(px, py, Math.exp(-event.deltaY * 0.001));
  }, { passive: false });
}

// Scale the view by ``factor`` keeping the map point under (px, py) where it is.
function zoomAbout(px, py, factor) {
  const [x, y] = screenToMap(px, py);
  view.scale *= factor;
  view.zoomed = true;
  const [x2, y2] = screenToMap(px, py);
  view.cx += x - x2;
  view.cy += y - y2;
  requestDraw();
}

// One finger of two moved from ``before`` to ``after``: zoom by how the span between the
// fingers changed, about their midpoint, and pan by how the midpoint moved.
function pinch(before, after, id) {
  const other = [...touching].find(([key]) => key !== id);
  if (!other) return;
  const [ox, oy] = other[1];
  const span0 = Math.hypot(before[0] - ox, before[1] - oy);
  const span1 = Math.hypot(after[0] - ox, after[1] - oy);
  const mid0 = [(before[0] + ox) / 2, (before[1] + oy) / 2];
  const mid1 = [(after[0] + ox) / 2, (after[1] + oy) / 2];
  if (span0 > 1 && span1 > 1) zoomAbout(mid1[0], mid1[1], span1 / span0);
  view.cx -= (mid1[0] - mid0[0]) / view.scale;
  view.cy += (mid1[1] - mid0[1]) / view.scale;
  view.zoomed = true;
  requestDraw();
}

export function listenToTheJoystick() {
  const stick = document.getElementById("joystick");
  const knob = document.getElementById("knob");
  let held = null;
  let timer = null;

  function stickCommand() {
    const limits = state.info ? state.info.teleop : { max_linear: 0.3, max_angular: 0.8 };
    command({ type: "teleop", linear_x: -held.dy * limits.max_linear,
      angular_z: -held.dx * limits.max_angular });
  }

  function moveKnob(event) {
    const r = stick.getBoundingClientRect();
    const radius = r.width / 2;
    let dx = (event.clientX - r.left - radius) / radius;
    let dy = (event.clientY - r.top - radius) / radius;
    const length = Math.hypot(dx, dy);
    if (length > 1) { dx /= length; dy /= length; }
    held = { dx, dy };
    knob.style.transform = `translate(${dx * radius * 0.7}px, ${dy * radius * 0.7}px)`;
  }

  function release() {
    if (!held) return;
    clearInterval(timer);
    held = { dx: 0, dy: 0 };
    stickCommand();
    held = null;
    knob.style.transform = "";
  }

  stick.addEventListener("pointerdown", (event) => {
    stick.setPointerCapture(event.pointerId);
    moveKnob(event);
    stickCommand();
    timer = setInterval(stickCommand, TELEOP_PERIOD_MS);
  });
  stick.addEventListener("pointermove", (event) => { if (held) moveKnob(event); });
  stick.addEventListener("pointerup", release);
  stick.addEventListener("pointercancel", release);
  stick.addEventListener("lostpointercapture", release);
  // A hidden tab's timers slow to one a second: stop rather than drive in bursts unattended.
  document.addEventListener("visibilitychange", () => { if (document.hidden) release(); });
  window.addEventListener("blur", release);
}

export function listenToTheButtons() {
  // The emergency stop: navd takes it without a token (stopping is always allowed); the
  // release needs one, like any command that lets the robot move.
  document.getElementById("estop").addEventListener("click", () => {
    command({ type: "estop", engaged: true });
    say("emergency stop sent", "bad");
  });
  document.getElementById("estop-release").addEventListener("click", () => {
    command({ type: "estop", engaged: false });
    say("release sent");
  });
  document.getElementById("cancel").addEventListener("click", () => {
    command({ type: "cancel" });
    say("cancel sent");
  });
  document.getElementById("fit").addEventListener("click", () => { view.zoomed = false; fit(); });
  const tokenInput = document.getElementById("token");
  tokenInput.value = localStorage.getItem("navd-token") || "";
  tokenInput.addEventListener("change", () => localStorage.setItem("navd-token", tokenInput.value));
}
