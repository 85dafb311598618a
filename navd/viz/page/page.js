// navd's operator page: the map with the robot, scan, route and keep-out zones from navd's
// live view (the Foxglove WebSocket protocol, JSON channels under /page/ and /status), and
// commands back on the /navd/command channel. No library, no build step: ES modules, each
// a part (model: what the page knows; stream: the WebSocket; picture: the canvas; panel:
// the status; controls: what the operator does).
import { state, view } from "./model.js";
import { fit, mapToScreen, requestDraw, screenToMap } from "./picture.js";
import { listenToTheButtons, listenToTheJoystick, listenToTheMap } from "./controls.js";
import { connect } from "./stream.js";

listenToTheMap();
listenToTheJoystick();
listenToTheButtons();
window.addEventListener("resize", requestDraw);

// What tests (and curious people) may ask the page.
window.navd = { state, view, mapToScreen, screenToMap, fit };

fetch("config.json").then((r) => r.json()).then((config) => {
  window.navdConfig = config;
  document.getElementById("token-box").hidden = Boolean(config.command_token);
  connect();
});
