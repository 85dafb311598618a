// The status panel: the link, safety, who drives, the goal, localization, the battery,
// and messages.
import { state } from "./model.js";

function setText(id, text, kind) {
  const element = document.getElementById(id);
  element.textContent = text;
  element.className = kind || "";
}

export function say(text, kind) { setText("message", text, kind); }

function number(value, digits, unit) {
  return value === null || value === undefined ? "?" : `${value.toFixed(digits)} ${unit}`;
}

export function showStatus() {
  setText("link", state.connected ? "connected" : "not connected: retrying",
    state.connected ? "ok" : "bad");
  const status = state.status || {};
  const safety = status.safety;
  if (safety) {
    setText("safety", safety.stopped ? `stopped: ${safety.reasons.join("; ")}` : "free to move",
      safety.stopped ? "bad" : "ok");
    // the release shows only while an emergency stop holds the robot
    const stopped = (safety.reasons || []).some((r) => r.startsWith("emergency stop"));
    document.getElementById("estop-release").hidden = !stopped;
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
  showBattery(status.battery);
}

function showBattery(battery) {
  document.getElementById("battery-box").hidden = !battery;
  if (!battery) return;
  const charge = battery.percentage === undefined ? "" : `${Math.round(battery.percentage * 100)}%, `;
  const charging = battery.charging ? ", charging" : "";
  const alarm = battery.alarm === "ok" ? "" : ` (${battery.alarm})`;
  setText("battery", `${charge}${battery.voltage_v.toFixed(1)} V${charging}${alarm}`,
    battery.alarm === "critical" ? "bad" : battery.alarm === "low" ? "warn" : "ok");
}
