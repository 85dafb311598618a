// navd's operator page: the map with the robot, scan, route and keep-out zones from navd's
// live view (the Foxglove WebSocket protocol, JSON channels under /page/ and /status), and
// commands back on the /navd/command channel: tap for a goal, drag for the initial pose,
// the joystick to drive by hand, a button to cancel. No library, no build step.
"use strict";

const SUBPROTOCOLS = ["foxglove.sdk.v1", "foxglove.websocket.v1"];
const TOPICS = ["/page/info", "/page/map", "/page/pose", "/page/scan", "/page/route",
  "/page/goal", "/status", "/goal_status"];
const COMMAND_TOPIC = "/navd/command";
const COMMAND_CHANNEL = 1;
const DRAG_PX = 12;          // a press that moves less than this is a tap (a goal)
const TELEOP_PERIOD_MS = 100; // joystick commands go out at 10 Hz (the daemon's deadman: 0.5 s)
const RECONNECT_MS = 1000;

const state = {
  info: null, map: null, pose: null, scans: {}, route: null, goal: null,
  status: null, goalStatus: null, connected: false,
};
// px per m, and the map point at the centre; the view follows the growing map until the
// person zooms
const view = { scale: 50, cx: 0, cy: 0, zoomed: false };
const canvas = document.getElementById("map");
const ctx = canvas.getContext("2d");
const mapImage = document.createElement("canvas");
let socket = null;
let channels = new Map();      // server channel id -> topic
let subscriptions = new Map(); // subscription id -> topic
let drawPending = false;

// --- the stream -------------------------------------------------------------------------

function connect() {
  const port = window.navdConfig.ws_port;
  socket = new WebSocket(`ws://${location.hostname}:${port}`, SUBPROTOCOLS);
  socket.binaryType = "arraybuffer";
  channels = new Map();
  subscriptions = new Map();
  socket.onopen = () => {
    state.connected = true;
    send({ op: "advertise", channels: [{ id: COMMAND_CHANNEL, topic: COMMAND_TOPIC,
      encoding: "json", schemaName: "navd.Command" }] });
    showStatus();
  };
  socket.onclose = () => {
    state.connected = false;
    showStatus();
    setTimeout(connect, RECONNECT_MS);
  };
  socket.onmessage = (event) => {
    if (typeof event.data === "string") onOp(JSON.parse(event.data));
    else onData(new DataView(event.data));
  };
}

function send(op) {
  if (socket && socket.readyState === WebSocket.OPEN) socket.send(JSON.stringify(op));
}

function onOp(op) {
  if (op.op === "advertise") {
    const wanted = [];
    for (const c of op.channels) {
      channels.set(c.id, c.topic);
      if (TOPICS.includes(c.topic)) {
        const id = subscriptions.size + 1;
        subscriptions.set(id, c.topic);
        wanted.push({ id, channelId: c.id });
      }
    }
    if (wanted.length) send({ op: "subscribe", subscriptions: wanted });
  } else if (op.op === "status") {
    say(op.message, op.level >= 1 ? "warn" : "");
  }
}

function onData(data) {
  if (data.getUint8(0) !== 1) return; // only message data
  const topic = subscriptions.get(data.getUint32(1, true));
  if (!topic) return;
  const text = new TextDecoder().decode(new Uint8Array(data.buffer, 13));
  take(topic, JSON.parse(text));
}

function take(topic, message) {
  switch (topic) {
    case "/page/info":
      state.info = message;
      document.getElementById("robot").textContent = message.robot;
      if (!message.commands) say("this view is read-only (viz.commands is false)", "warn");
      break;
    case "/page/map": state.map = message; paintMap(message); break;
    case "/page/pose": state.pose = message; break;
    case "/page/scan": state.scans[message.lidar || ""] = scanPoints(message); break;
    case "/page/route": state.route = message; break;
    case "/page/goal": state.goal = message; break;
    case "/status": state.status = message; break;
    case "/goal_status": state.goalStatus = message; break;
  }
  if (topic === "/status" || topic === "/goal_status" || topic === "/page/pose") showStatus();
  document.body.dataset.ready = state.map && state.pose ? "1" : "0";
  requestDraw();
}

function scanPoints(message) {
  // base64 of little-endian int32 centimetres, x0 y0 x1 y1 ... in the map frame
  const raw = atob(message.points_cm);
  const bytes = new Uint8Array(raw.length);
  for (let i = 0; i < raw.length; i++) bytes[i] = raw.charCodeAt(i);
  const cm = new Int32Array(bytes.buffer);
  const points = new Float64Array(cm.length);
  for (let i = 0; i < cm.length; i++) points[i] = cm[i] / 100;
  return { stamp: message.stamp, points };
}

// --- commands ---------------------------------------------------------------------------

function command(frame) {
  if (!socket || socket.readyState !== WebSocket.OPEN) {
    say("not connected: command not sent", "bad");
    return;
  }
  // A token typed in (tcp.token, from another machine) or the run's own, which navd gives a
  // browser on the robot itself.
  const token = document.getElementById("token").value || window.navdConfig.command_token;
  if (token) frame.token = token;
  const payload = new TextEncoder().encode(JSON.stringify(frame));
  const message = new Uint8Array(5 + payload.length);
  const header = new DataView(message.buffer);
  header.setUint8(0, 1);
  header.setUint32(1, COMMAND_CHANNEL, true);
  message.set(payload, 5);
  socket.send(message);
}

// --- the picture ------------------------------------------------------------------------

function paintMap(map) {
  mapImage.width = map.width;
  mapImage.height = map.height;
  const raw = atob(map.cells);
  const image = new ImageData(map.width, map.height);
  for (let row = 0; row < map.height; row++) {
    const flipped = (map.height - 1 - row) * map.width; // row 0 is the map's bottom
    for (let col = 0; col < map.width; col++) {
      let v = raw.charCodeAt(row * map.width + col);
      if (v > 127) v -= 256;
      const shade = v < 0 ? 127 : 255 - Math.round(v * 2.55);
      const at = (flipped + col) * 4;
      image.data[at] = image.data[at + 1] = image.data[at + 2] = shade;
      image.data[at + 3] = 255;
    }
  }
  mapImage.getContext("2d").putImageData(image, 0, 0);
  if (!view.zoomed) fit();
}

function fit() {
  const map = state.map;
  if (!map) return;
  const w = map.width * map.resolution, h = map.height * map.resolution;
  view.scale = 0.95 * Math.min(canvas.clientWidth / w, canvas.clientHeight / h);
  view.cx = map.origin[0] + w / 2;
  view.cy = map.origin[1] + h / 2;
  requestDraw();
}

function mapToScreen(x, y) {
  return [canvas.clientWidth / 2 + (x - view.cx) * view.scale,
    canvas.clientHeight / 2 - (y - view.cy) * view.scale];
}

function screenToMap(px, py) {
  return [view.cx + (px - canvas.clientWidth / 2) / view.scale,
    view.cy - (py - canvas.clientHeight / 2) / view.scale];
}

function requestDraw() {
  if (drawPending) return;
  drawPending = true;
  requestAnimationFrame(draw);
}

function polyline(points, close) {
  ctx.beginPath();
  points.forEach(([x, y], i) => {
    const [px, py] = mapToScreen(x, y);
    if (i === 0) ctx.moveTo(px, py); else ctx.lineTo(px, py);
  });
  if (close) ctx.closePath();
}

function arrow(x, y, yaw, length, color) {
  const [px, py] = mapToScreen(x, y);
  ctx.strokeStyle = color;
  ctx.lineWidth = 3;
  ctx.beginPath();
  ctx.moveTo(px, py);
  ctx.lineTo(px + Math.cos(yaw) * length, py - Math.sin(yaw) * length);
  ctx.stroke();
}

function draw() {
  drawPending = false;
  const ratio = window.devicePixelRatio || 1;
  const width = canvas.clientWidth, height = canvas.clientHeight;
  if (canvas.width !== Math.round(width * ratio) || canvas.height !== Math.round(height * ratio)) {
    canvas.width = Math.round(width * ratio);
    canvas.height = Math.round(height * ratio);
  }
  ctx.setTransform(ratio, 0, 0, ratio, 0, 0);
  ctx.clearRect(0, 0, width, height);
  const map = state.map;
  if (map) {
    const [left, top] = mapToScreen(map.origin[0], map.origin[1] + map.height * map.resolution);
    const size = map.resolution * view.scale;
    ctx.imageSmoothingEnabled = false;
    ctx.drawImage(mapImage, left, top, map.width * size, map.height * size);
  }
  if (state.info) {
    ctx.fillStyle = "rgba(220, 40, 40, 0.3)";
    ctx.strokeStyle = "rgba(220, 40, 40, 0.9)";
    ctx.lineWidth = 2;
    for (const zone of state.info.keep_out) { polyline(zone, true); ctx.fill(); ctx.stroke(); }
  }
  if (state.route && state.route.points.length) {
    ctx.strokeStyle = "#2f7de1";
    ctx.lineWidth = 3;
    polyline(state.route.points, false);
    ctx.stroke();
  }
  if (state.goal) {
    const [gx, gy] = mapToScreen(state.goal.x, state.goal.y);
    ctx.fillStyle = "#2fb84f";
    ctx.beginPath();
    ctx.arc(gx, gy, 7, 0, 2 * Math.PI);
    ctx.fill();
    if (state.goal.yaw !== null) arrow(state.goal.x, state.goal.y, state.goal.yaw, 22, "#2fb84f");
  }
  ctx.fillStyle = "#ff3b30";
  const newest = Math.max(...Object.values(state.scans).map((s) => s.stamp));
  for (const scan of Object.values(state.scans)) {
    if (scan.stamp < newest - 1.0) continue;  // a lidar gone quiet: its points are old
    const p = scan.points;
    for (let i = 0; i + 1 < p.length; i += 2) {
      const [px, py] = mapToScreen(p[i], p[i + 1]);
      ctx.fillRect(px - 1.5, py - 1.5, 3, 3);
    }
  }
  if (state.pose) drawRobot(state.pose);
  if (press && press.dragging) {
    const [x0, y0] = screenToMap(press.x0, press.y0);
    arrow(x0, y0, Math.atan2(-(press.y - press.y0), press.x - press.x0), 40, "#f5c04a");
  }
}

function drawRobot(pose) {
  const [px, py] = mapToScreen(pose.x, pose.y);
  const outline = state.info ? state.info.footprint : { kind: "circle", radius: 0.2 };
  ctx.save();
  ctx.translate(px, py);
  ctx.rotate(-pose.yaw);
  ctx.fillStyle = "rgba(255, 170, 0, 0.85)";
  ctx.strokeStyle = "#222";
  ctx.lineWidth = 2;
  ctx.beginPath();
  if (outline.kind === "circle") {
    ctx.arc(0, 0, Math.max(outline.radius * view.scale, 4), 0, 2 * Math.PI);
  } else {
    const l = outline.length * view.scale, w = outline.width * view.scale;
    ctx.rect(-l / 2, -w / 2, l, w);
  }
  ctx.fill();
  ctx.stroke();
  ctx.beginPath();
  ctx.moveTo(0, 0);
  ctx.lineTo(Math.max((outline.radius || outline.length / 2) * view.scale, 8), 0);
  ctx.stroke();
  ctx.restore();
  if (pose.std_xy * view.scale > 3) {
    ctx.strokeStyle = "rgba(255, 170, 0, 0.6)";
    ctx.beginPath();
    ctx.arc(px, py, 2 * pose.std_xy * view.scale, 0, 2 * Math.PI);
    ctx.stroke();
  }
}

// --- the status panel -------------------------------------------------------------------

function setText(id, text, kind) {
  const element = document.getElementById(id);
  element.textContent = text;
  element.className = kind || "";
}

function say(text, kind) { setText("message", text, kind); }

function number(value, digits, unit) {
  return value === null || value === undefined ? "?" : `${value.toFixed(digits)} ${unit}`;
}

function showStatus() {
  setText("link", state.connected ? "connected" : "not connected: retrying",
    state.connected ? "ok" : "bad");
  const status = state.status || {};
  const safety = status.safety;
  if (safety) {
    setText("safety", safety.stopped ? `stopped: ${safety.reasons.join("; ")}` : "free to move",
      safety.stopped ? "bad" : "ok");
  }
  const drive = status.drive;
  const pose = state.pose;
  const speed = pose ? `, ${number(pose.linear, 2, "m/s")}` : "";
  if (drive && drive.mode === "manual") setText("drive", `by hand (${drive.operator})${speed}`, "warn");
  else setText("drive", `navigator${speed}`);
  const goal = state.goalStatus;
  if (goal) {
    const left = goal.state === "active"
      ? ` ${number(goal.distance_remaining_m, 1, "m")} to go, ${number(goal.eta_s, 0, "s")}` : "";
    const why = goal.reason ? ` (${goal.reason})` : "";
    setText("goal", `${goal.goal_id}: ${goal.state}${left}${why}`,
      goal.state === "failed" ? "bad" : goal.state === "reached" ? "ok" : "");
  }
  const where = status.localization;
  if (where) {
    setText("localization", `${where.state}, ±${number(where.position_std_m, 2, "m")}`,
      where.state === "ok" ? "ok" : where.state === "lost" ? "bad" : "warn");
  }
}

// --- pointer: tap for a goal, drag for the initial pose, wheel to zoom ------------------

let press = null;

canvas.addEventListener("pointerdown", (event) => {
  canvas.setPointerCapture(event.pointerId);
  const r = canvas.getBoundingClientRect();
  const x = event.clientX - r.left, y = event.clientY - r.top;
  press = { x0: x, y0: y, x, y, dragging: false };
});

canvas.addEventListener("pointermove", (event) => {
  if (!press) return;
  const r = canvas.getBoundingClientRect();
  press.x = event.clientX - r.left;
  press.y = event.clientY - r.top;
  press.dragging = press.dragging || Math.hypot(press.x - press.x0, press.y - press.y0) > DRAG_PX;
  requestDraw();
});

canvas.addEventListener("pointerup", () => {
  if (!press) return;
  const [x, y] = screenToMap(press.x0, press.y0);
  if (press.dragging) {
    const yaw = Math.atan2(-(press.y - press.y0), press.x - press.x0);
    command({ type: "initial_pose", x, y, yaw });
    say(`initial pose (${x.toFixed(2)}, ${y.toFixed(2)}) sent`);
  } else {
    command({ type: "goal", x, y });
    say(`goal (${x.toFixed(2)}, ${y.toFixed(2)}) sent`);
  }
  press = null;
  requestDraw();
});

canvas.addEventListener("pointercancel", () => { press = null; requestDraw(); });

canvas.addEventListener("wheel", (event) => {
  event.preventDefault();
  const r = canvas.getBoundingClientRect();
  const [x, y] = screenToMap(event.clientX - r.left, event.clientY - r.top);
  view.scale *= Math.exp(-event.deltaY * 0.001);
  view.zoomed = true;
  const [x2, y2] = screenToMap(event.clientX - r.left, event.clientY - r.top);
  view.cx += x - x2;
  view.cy += y - y2;
  requestDraw();
}, { passive: false });

// --- the joystick: held, it drives at 10 Hz; let go, one stop and silence (deadman) -----

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
  let dx = (event.clientX - r.left - radius) / radius, dy = (event.clientY - r.top - radius) / radius;
  const length = Math.hypot(dx, dy);
  if (length > 1) { dx /= length; dy /= length; }
  held = { dx, dy };
  knob.style.transform = `translate(${dx * radius * 0.7}px, ${dy * radius * 0.7}px)`;
}

stick.addEventListener("pointerdown", (event) => {
  stick.setPointerCapture(event.pointerId);
  moveKnob(event);
  stickCommand();
  timer = setInterval(stickCommand, TELEOP_PERIOD_MS);
});
stick.addEventListener("pointermove", (event) => { if (held) moveKnob(event); });

function release() {
  if (!held) return;
  clearInterval(timer);
  held = { dx: 0, dy: 0 };
  stickCommand();
  held = null;
  knob.style.transform = "";
}
stick.addEventListener("pointerup", release);
stick.addEventListener("pointercancel", release);
stick.addEventListener("lostpointercapture", release);
// A hidden tab's timers slow to one a second: stop rather than drive in bursts unattended.
document.addEventListener("visibilitychange", () => { if (document.hidden) release(); });
window.addEventListener("blur", release);

document.getElementById("cancel").addEventListener("click", () => {
  command({ type: "cancel" });
  say("cancel sent");
});
document.getElementById("fit").addEventListener("click", () => { view.zoomed = false; fit(); });
const tokenInput = document.getElementById("token");
tokenInput.value = localStorage.getItem("navd-token") || "";
tokenInput.addEventListener("change", () => localStorage.setItem("navd-token", tokenInput.value));
window.addEventListener("resize", requestDraw);

// What tests (and curious people) may ask the page.
window.navd = { state, view, mapToScreen, screenToMap, fit };

fetch("config.json").then((r) => r.json()).then((config) => {
  window.navdConfig = config;
  document.getElementById("token-box").hidden = Boolean(config.command_token);
  connect();
});
