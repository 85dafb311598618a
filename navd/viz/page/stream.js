// The live view's stream (the Foxglove WebSocket protocol): the page's JSON channels in, and
// commands out on /navd/command, each carrying the token.
import { state } from "./model.js";
import { paintMap, requestDraw } from "./picture.js";
import { say, showStatus } from "./panel.js";

const SUBPROTOCOLS = ["foxglove.sdk.v1", "foxglove.websocket.v1"];
const ENDED = ["reached", "failed", "canceled"]; // a goal's last states
const TOPICS = ["/page/info", "/page/map", "/page/pose", "/page/scan", "/page/route",
  "/page/goal", "/status", "/goal_status"];
const COMMAND_TOPIC = "/navd/command";
const COMMAND_CHANNEL = 1;
const RECONNECT_MS = 1000;

let socket = null;
let subscriptions = new Map(); // subscription id -> topic

export function connect() {
  const port = window.navdConfig.ws_port;
  socket = new WebSocket(`ws://${location.hostname}:${port}`, SUBPROTOCOLS);
  socket.binaryType = "arraybuffer";
  subscriptions = new Map();
  socket.onopen = () => {
    state.connected = true;
    // what the last connection said is the past (a restarted daemon has none of it)
    Object.assign(state, { route: null, goal: null, goalStatus: null, status: null, scans: {} });
    send({ op: "advertise", channels: [{ id: COMMAND_CHANNEL, topic: COMMAND_TOPIC,
      encoding: "json", schemaName: "navd.Command" }] });
    showStatus();
  };
  socket.onclose = () => {
    state.connected = false;
    showStatus();
    setTimeout(reconnect, RECONNECT_MS);
  };
  socket.onmessage = (event) => {
    if (typeof event.data === "string") onOp(JSON.parse(event.data));
    else onData(new DataView(event.data));
  };
}

// A restarted daemon has a new command token and perhaps a new port: ask for them again
// before connecting (a page kept open across a restart must not send the old token).
function reconnect() {
  fetch("config.json", { cache: "no-store" })
    .then((r) => r.json())
    .then((config) => { window.navdConfig = config; connect(); })
    .catch(() => setTimeout(reconnect, RECONNECT_MS));
}

function send(op) {
  if (socket && socket.readyState === WebSocket.OPEN) socket.send(JSON.stringify(op));
}

function onOp(op) {
  if (op.op === "advertise") {
    const wanted = [];
    for (const c of op.channels) {
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
    case "/page/route": if (!ended(message.goal_id)) state.route = message; break;
    case "/page/goal": if (!ended(message.goal_id)) state.goal = message; break;
    case "/status": state.status = message; break;
    case "/goal_status":
      if (ENDED.includes(message.state)) {
        // the goal over, its marker and route go; not another's (a goal replaced by a new
        // one ends after the new one is drawn)
        if (state.goal && state.goal.goal_id === message.goal_id) state.goal = null;
        if (state.route && state.route.goal_id === message.goal_id) state.route = null;
      }
      if (!state.goalStatus || message.goal_id === state.goalStatus.goal_id
          || !ENDED.includes(message.state)) state.goalStatus = message;
      break;
  }
  if (topic === "/status" || topic === "/goal_status" || topic === "/page/pose") showStatus();
  document.body.dataset.ready = state.map && state.pose ? "1" : "0";
  requestDraw();
}

// A goal known to have ended: its marker or route, sent again to a page that just loaded,
// is not drawn.
function ended(goalId) {
  const known = state.goalStatus;
  return Boolean(known && known.goal_id === goalId && ENDED.includes(known.state));
}

function scanPoints(message) {
  // base64 of little-endian int32 centimetres, x0 y0 x1 y1 ... in the map frame
  const raw = atob(message.points_cm);
  const bytes = new Uint8Array(raw.length);
  for (let i = 0; i < raw.length; i++) bytes[i] = raw.charCodeAt(i);
  const cm = new Int32Array(bytes.buffer);
  const points = new Float64Array(cm.length);
  for (let i = 0; i < cm.length; i++) points[i] = cm[i] / 100;
  return { stamp: message.stamp, arrived: performance.now(), points };
}

export function command(frame) {
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
