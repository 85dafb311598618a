// The picture: the map, keep-out zones, route, goal, scans and the robot on a canvas, and
// the conversion between the map frame [m] and the canvas [px].
import { pointer, state, view } from "./model.js";

const SCAN_SHOWN_MS = 1000; // a scan is drawn this long after it came, no longer

const canvas = document.getElementById("map");
const ctx = canvas.getContext("2d");
const mapImage = document.createElement("canvas");
let drawPending = false;

export function paintMap(map) {
  mapImage.width = map.width;
  mapImage.height = map.height;
  const raw = atob(map.cells);
  const image = new ImageData(map.width, map.height);
  let c0 = map.width, c1 = -1, r0 = map.height, r1 = -1; // the known cells' bounds
  for (let row = 0; row < map.height; row++) {
    const flipped = (map.height - 1 - row) * map.width; // row 0 is the map's bottom
    for (let col = 0; col < map.width; col++) {
      let v = raw.charCodeAt(row * map.width + col);
      if (v > 127) v -= 256;
      if (v >= 0) {
        c0 = Math.min(c0, col); c1 = Math.max(c1, col);
        r0 = Math.min(r0, row); r1 = Math.max(r1, row);
      }
      const shade = v < 0 ? 127 : 255 - Math.round(v * 2.55);
      const at = (flipped + col) * 4;
      image.data[at] = image.data[at + 1] = image.data[at + 2] = shade;
      image.data[at + 3] = 255;
    }
  }
  mapImage.getContext("2d").putImageData(image, 0, 0);
  map.known = c1 < 0 ? null : [c0, r0, c1 + 1, r1 + 1]; // [cells) of what was seen
  if (!view.zoomed) fit();
}

// Fit what is known of the map (not the unknown margin around it) into the canvas.
export function fit() {
  const map = state.map;
  if (!map) return;
  const [c0, r0, c1, r1] = map.known || [0, 0, map.width, map.height];
  const w = (c1 - c0) * map.resolution, h = (r1 - r0) * map.resolution;
  view.scale = 0.95 * Math.min(canvas.clientWidth / w, canvas.clientHeight / h);
  view.cx = map.origin.x + (c0 * map.resolution) + w / 2;
  view.cy = map.origin.y + (r0 * map.resolution) + h / 2;
  requestDraw();
}

export function mapToScreen(x, y) {
  return [canvas.clientWidth / 2 + (x - view.cx) * view.scale,
    canvas.clientHeight / 2 - (y - view.cy) * view.scale];
}

export function screenToMap(px, py) {
  return [view.cx + (px - canvas.clientWidth / 2) / view.scale,
    view.cy - (py - canvas.clientHeight / 2) / view.scale];
}

export function requestDraw() {
  if (drawPending) return;
  drawPending = true;
  requestAnimationFrame(draw);
}

// points: [{x, y}] in the map frame [m], as the page's JSON has them
function polyline(points, close) {
  ctx.beginPath();
  points.forEach(({ x, y }, i) => {
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
    const [left, top] = mapToScreen(map.origin.x, map.origin.y + map.height * map.resolution);
    const size = map.resolution * view.scale;
    ctx.imageSmoothingEnabled = false;
    ctx.drawImage(mapImage, left, top, map.width * size, map.height * size);
  }
  if (state.info) {
    ctx.fillStyle = "rgba(220, 40, 40, 0.3)";
    ctx.strokeStyle = "rgba(220, 40, 40, 0.9)";
    ctx.lineWidth = 2;
    for (const zone of state.info.keep_out) { polyline(zone.points, true); ctx.fill(); ctx.stroke(); }
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
    if (state.goal.yaw !== undefined) arrow(state.goal.x, state.goal.y, state.goal.yaw, 22, "#2fb84f");
  }
  ctx.fillStyle = "#ff3b30";
  const now = performance.now();
  for (const scan of Object.values(state.scans)) {
    // a lidar gone quiet (the only one too): its last points are not what is there now
    if (now - scan.arrived > SCAN_SHOWN_MS) continue;
    const p = scan.points;
    for (let i = 0; i + 1 < p.length; i += 2) {
      const [px, py] = mapToScreen(p[i], p[i + 1]);
      ctx.fillRect(px - 1.5, py - 1.5, 3, 3);
    }
  }
  if (state.pose) drawRobot(state.pose);
  const press = pointer.press;
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
