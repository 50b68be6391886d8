// The map: a pan/zoom camera over the arena and the layers drawn on it (world model, truth,
// goals, trajectory, plan, events, robot, sensor rays, metre scale).
const L = 0.226, HEAD = 0.055, R = 0.075; // unit length, head length, unit radius (m)

export const STYLE = {
  known: { fill: "#6b6b6b", stroke: "#333" },
  truth: { stroke: "#c0392b" },
  sensed: "rgba(142,68,173,0.75)",
  contact: "#e67e22",
  goal: "#d08a00", reached: "#2a9d2a",
  trail: "#1f77b4", plan: "#0a7f8c",
  robot: "rgba(31,119,180,0.55)", head: "#d62728",
  rayHit: "rgba(214,39,40,0.9)", rayFree: "rgba(214,39,40,0.22)",
  events: {
    replan: { color: "#0a7f8c", shape: "diamond", label: "replan" },
    collision: { color: "#d62728", shape: "cross", label: "contact" },
    goal_reached: { color: "#2a9d2a", shape: "star", label: "goal reached" },
    deform: { color: "#8e44ad", shape: "triangle", label: "deformation" },
    dropout: { color: "#7f8c8d", shape: "square", label: "sensor dropout" },
  },
};

export const LEGEND = [
  ["known obstacle", `background:${STYLE.known.fill}`],
  ["sensed occupancy", `background:${STYLE.sensed}`],
  ["contact", `background:${STYLE.contact}`],
  ["truth (hidden obstacle)", `border:2px dashed ${STYLE.truth.stroke}`],
  ["goal / reached", `border:2px solid ${STYLE.goal};border-radius:50%;box-shadow:inset 0 0 0 2px ${STYLE.reached}`],
  ["trajectory", `border-top:2px solid ${STYLE.trail};height:0`],
  ["plan (primitive ids)", `border-top:2px dashed ${STYLE.plan};height:0`],
  ["sensor ray: hit / nothing", `border-top:2px solid ${STYLE.rayHit};border-bottom:2px solid ${STYLE.rayFree};height:2px`],
  ...Object.values(STYLE.events).map((e) => [e.label, `color:${e.color};text-align:center;line-height:10px`, e.shape]),
];

const SYMBOLS = { diamond: "◆", cross: "✕", star: "★", triangle: "▲", square: "■" };

/** The legend's HTML. */
export function legendHtml() {
  return LEGEND.map(([label, css, shape]) =>
    `<div><i style="${css}">${shape ? SYMBOLS[shape] : ""}</i>${label}</div>`).join("");
}

/** A camera: world (m) to screen (px), with pan and zoom. */
export class Camera {
  constructor() { this.cx = 0; this.cy = 0; this.scale = 50; this.w = 1; this.h = 1; }
  X(x) { return (x - this.cx) * this.scale + this.w / 2; }
  Y(y) { return this.h / 2 - (y - this.cy) * this.scale; }
  toWorld(px, py) { return [(px - this.w / 2) / this.scale + this.cx, (this.h / 2 - py) / this.scale + this.cy]; }
  resize(canvas) { this.w = canvas.clientWidth || this.w; this.h = canvas.clientHeight || this.h; }
  fit(b, margin = 0.05) {
    this.cx = (b.xmin + b.xmax) / 2; this.cy = (b.ymin + b.ymax) / 2;
    this.scale = Math.min(this.w / (b.xmax - b.xmin), this.h / (b.ymax - b.ymin)) * (1 - 2 * margin);
  }
  zoomAt(px, py, factor) {
    const [wx, wy] = this.toWorld(px, py);
    this.scale = Math.min(5000, Math.max(2, this.scale * factor));
    const [nx, ny] = this.toWorld(px, py);
    this.cx += wx - nx; this.cy += wy - ny;
  }
  pan(dx, dy) { this.cx -= dx / this.scale; this.cy += dy / this.scale; }
}

/** Wheel zooms about the cursor, dragging pans, a double-click calls ``onFit``. */
export function attachControls(canvas, cam, onFit) {
  canvas.addEventListener("wheel", (e) => {
    e.preventDefault();
    cam.zoomAt(e.offsetX, e.offsetY, Math.exp(-e.deltaY * 0.0015));
  }, { passive: false });
  let drag = null;
  canvas.addEventListener("pointerdown", (e) => { drag = [e.clientX, e.clientY]; canvas.setPointerCapture(e.pointerId); });
  canvas.addEventListener("pointermove", (e) => {
    if (!drag) return;
    cam.pan(e.clientX - drag[0], e.clientY - drag[1]); drag = [e.clientX, e.clientY];
  });
  canvas.addEventListener("pointerup", () => { drag = null; });
  canvas.addEventListener("dblclick", onFit);
}

function path(ctx, cam, pts, close) {
  ctx.beginPath();
  pts.forEach(([x, y], i) => (i ? ctx.lineTo(cam.X(x), cam.Y(y)) : ctx.moveTo(cam.X(x), cam.Y(y))));
  if (close) ctx.closePath();
}

function rect(o) {
  const c = Math.cos(o.angle || 0), s = Math.sin(o.angle || 0);
  return [[-1, -1], [1, -1], [1, 1], [-1, 1]].map(([dx, dy]) => {
    const lx = dx * o.width / 2, ly = dy * o.height / 2;
    return [o.x + c * lx - s * ly, o.y + s * lx + c * ly];
  });
}

function obstacle(ctx, cam, o) {
  if (o.type === "circle") { ctx.beginPath(); ctx.arc(cam.X(o.x), cam.Y(o.y), o.radius * cam.scale, 0, 2 * Math.PI); }
  else path(ctx, cam, o.type === "polygon" ? o.points : rect(o), true);
}

export function marker(ctx, x, y, shape, color, size = 6) {
  ctx.save(); ctx.fillStyle = color; ctx.strokeStyle = color; ctx.lineWidth = 2; ctx.beginPath();
  if (shape === "cross") { ctx.moveTo(x - size, y - size); ctx.lineTo(x + size, y + size); ctx.moveTo(x + size, y - size); ctx.lineTo(x - size, y + size); ctx.stroke(); }
  else if (shape === "diamond") { ctx.moveTo(x, y - size); ctx.lineTo(x + size, y); ctx.lineTo(x, y + size); ctx.lineTo(x - size, y); ctx.fill(); }
  else if (shape === "triangle") { ctx.moveTo(x, y - size); ctx.lineTo(x + size, y + size); ctx.lineTo(x - size, y + size); ctx.fill(); }
  else if (shape === "square") { ctx.rect(x - size * 0.8, y - size * 0.8, size * 1.6, size * 1.6); ctx.fill(); }
  else { // star
    for (let i = 0; i < 10; i++) {
      const r = i % 2 ? size * 0.45 : size * 1.2, a = -Math.PI / 2 + (i * Math.PI) / 5;
      i ? ctx.lineTo(x + r * Math.cos(a), y + r * Math.sin(a)) : ctx.moveTo(x + r * Math.cos(a), y + r * Math.sin(a));
    }
    ctx.fill();
  }
  ctx.restore();
}

/** A metre scale bar of a round length (1, 2 or 5 × 10^k m) near 120 px, bottom left. */
function scaleBar(ctx, cam) {
  const target = 120 / cam.scale, k = Math.pow(10, Math.floor(Math.log10(target)));
  const metres = [1, 2, 5, 10].map((m) => m * k).filter((m) => m <= target).pop() || k;
  const px = metres * cam.scale, x0 = 16, y0 = cam.h - 18;
  ctx.save(); ctx.strokeStyle = "#222"; ctx.lineWidth = 2; ctx.beginPath();
  ctx.moveTo(x0, y0 - 5); ctx.lineTo(x0, y0); ctx.lineTo(x0 + px, y0); ctx.lineTo(x0 + px, y0 - 5); ctx.stroke();
  ctx.fillStyle = "#222"; ctx.font = "12px system-ui"; ctx.textAlign = "center";
  const text = metres >= 1 ? `${+metres.toPrecision(3)} m` : `${+(metres * 100).toPrecision(3)} cm`;
  ctx.fillText(text, x0 + px / 2, y0 - 6);
  ctx.restore();
  return text;
}

function robot(ctx, cam, p) {
  let th = p.psi, x = p.x, y = p.y;
  const joints = [[x, y]];
  for (let i = 0; i < 4; i++) {
    x += L * Math.cos(th); y += L * Math.sin(th); joints.push([x, y]);
    if (i < 3) th += (p.joints || [0, 0, 0])[i] || 0;
  }
  ctx.save(); ctx.lineCap = "round"; ctx.lineJoin = "round";
  ctx.lineWidth = 2 * R * cam.scale; ctx.strokeStyle = STYLE.robot; path(ctx, cam, joints); ctx.stroke();
  const fwd = p.psi + Math.PI, tip = [p.x + HEAD * Math.cos(fwd), p.y + HEAD * Math.sin(fwd)];
  ctx.fillStyle = STYLE.head; ctx.beginPath();
  ctx.arc(cam.X(tip[0]), cam.Y(tip[1]), Math.max(3, 0.05 * cam.scale), 0, 2 * Math.PI); ctx.fill();
  ctx.restore();
}

/** Rays as read: a hit ends in a dot at its distance; "nothing in range" is a faint ray of the
 * full range; a dropout (no reading) is not drawn. */
function rays(ctx, cam, list) {
  ctx.save(); ctx.lineWidth = 1.5;
  for (const r of list) {
    if (r.distance === null) continue;
    const d = r.hit ? r.distance : r.max_range;
    const [ox, oy] = r.origin, ex = ox + d * Math.cos(r.angle), ey = oy + d * Math.sin(r.angle);
    ctx.strokeStyle = r.hit ? STYLE.rayHit : STYLE.rayFree; ctx.setLineDash(r.hit ? [] : [4, 3]);
    path(ctx, cam, [[ox, oy], [ex, ey]]); ctx.stroke();
    if (r.hit) { ctx.fillStyle = STYLE.rayHit; ctx.beginPath(); ctx.arc(cam.X(ex), cam.Y(ey), 3, 0, 2 * Math.PI); ctx.fill(); }
  }
  ctx.restore();
}

/** Primitive id of a plan action: a lattice move names it as its last argument; otherwise the
 * library primitives it is grounded with, else the action's name and arguments. */
export function primitiveOf(a) {
  const last = a.args && a.args.length ? a.args[a.args.length - 1] : "";
  if (a.name === "move" && last) return last;
  const g = a.grounding || {};
  if (g.primitives && g.primitives.length) return g.primitives.join("+");
  return [a.name, ...(a.args || [])].join(" ");
}

/** The plan: a dashed line from the robot through each action's target, each labelled with its
 * primitive id (labels that would overlap one already drawn are left out; zoom in to see them). */
function plan(ctx, cam, actions, from, current, start = 0) {
  const pts = actions.slice(start).filter((a) => a.target);
  if (!pts.length) return [];
  ctx.save(); ctx.strokeStyle = STYLE.plan; ctx.lineWidth = 2; ctx.setLineDash([6, 4]);
  path(ctx, cam, [[from.x, from.y], ...pts.map((a) => [a.target.x, a.target.y])]); ctx.stroke(); ctx.setLineDash([]);
  ctx.font = "11px ui-monospace, monospace"; ctx.textBaseline = "middle";
  const boxes = [], drawn = [];
  const order = [...pts.keys()].sort((i, j) => (pts[j] === current) - (pts[i] === current));
  for (const i of order) {
    const a = pts[i], x = cam.X(a.target.x), y = cam.Y(a.target.y);
    ctx.fillStyle = a === current ? "#e0a000" : STYLE.plan;
    ctx.beginPath(); ctx.arc(x, y, a === current ? 5 : 3, 0, 2 * Math.PI); ctx.fill();
    const text = `${actions.indexOf(a) + 1} ${primitiveOf(a)}`, w = ctx.measureText(text).width + 6;
    const box = [x + 6, y - 8, x + 6 + w, y + 8];
    if (boxes.some((b) => box[0] < b[2] && b[0] < box[2] && box[1] < b[3] && b[1] < box[3])) continue;
    boxes.push(box); drawn.push(text);
    ctx.fillStyle = "rgba(255,255,255,0.85)"; ctx.fillRect(box[0], box[1], w, 16);
    ctx.fillStyle = a === current ? "#8a5a00" : STYLE.plan; ctx.fillText(text, box[0] + 3, y);
  }
  ctx.restore();
  return drawn;
}

/** Draw everything of ``scene`` on the canvas; returns what was drawn (for tests). */
export function drawScene(canvas, cam, scene) {
  const ctx = canvas.getContext("2d"), dpr = window.devicePixelRatio || 1;
  const w = canvas.clientWidth, h = canvas.clientHeight;
  if (canvas.width !== Math.round(w * dpr) || canvas.height !== Math.round(h * dpr)) {
    canvas.width = Math.round(w * dpr); canvas.height = Math.round(h * dpr);
  }
  cam.w = w; cam.h = h;
  ctx.setTransform(dpr, 0, 0, dpr, 0, 0); ctx.clearRect(0, 0, w, h);
  const out = { labels: [], scale: "", events: 0, rays: 0 };
  const m = scene.mission;
  if (!m) return out;
  const b = m.request.bounds;
  ctx.strokeStyle = "#999"; ctx.lineWidth = 1;
  ctx.strokeRect(cam.X(b.xmin), cam.Y(b.ymax), (b.xmax - b.xmin) * cam.scale, (b.ymax - b.ymin) * cam.scale);
  for (const o of m.request.obstacles || []) {
    if (!o.known) continue;
    obstacle(ctx, cam, o); ctx.fillStyle = STYLE.known.fill; ctx.fill(); ctx.strokeStyle = STYLE.known.stroke; ctx.stroke();
  }
  const cell = (scene.world.resolution || 0.05) * cam.scale;
  ctx.fillStyle = STYLE.sensed;
  const inside = ([x, y]) => x >= b.xmin && x <= b.xmax && y >= b.ymin && y <= b.ymax;
  for (const [x, y] of scene.world.sensed.filter(inside)) ctx.fillRect(cam.X(x) - cell / 2, cam.Y(y) - cell / 2, cell, cell);
  for (const [x, y] of scene.world.contacts) marker(ctx, cam.X(x), cam.Y(y), "square", STYLE.contact, Math.max(2, cell / 2));
  if (scene.truth) {
    ctx.save(); ctx.setLineDash([5, 4]); ctx.lineWidth = 2; ctx.strokeStyle = STYLE.truth.stroke;
    for (const o of m.request.obstacles || []) if (!o.known) { obstacle(ctx, cam, o); ctx.stroke(); }
    ctx.restore();
  }
  (m.goals || []).forEach((g, i) => {
    ctx.beginPath(); ctx.arc(cam.X(g.x), cam.Y(g.y), Math.max(g.tolerance * cam.scale, 6), 0, 2 * Math.PI);
    ctx.strokeStyle = g.reached ? STYLE.reached : STYLE.goal; ctx.lineWidth = 2; ctx.stroke();
    ctx.fillStyle = ctx.strokeStyle; ctx.font = "11px system-ui"; ctx.fillText(`G${i + 1}`, cam.X(g.x) + 8, cam.Y(g.y) - 8);
  });
  if (scene.trail.length) {
    ctx.strokeStyle = STYLE.trail; ctx.lineWidth = 2; path(ctx, cam, scene.trail.map((r) => [r[1], r[2]])); ctx.stroke();
  }
  const pose = scene.pose || m.pose;
  if (pose) out.labels = plan(ctx, cam, scene.plan, scene.planFrom || pose, scene.current, scene.planStart || 0);
  for (const e of scene.events) {
    const st = STYLE.events[e.kind];
    if (!st || e.x === undefined) continue;
    marker(ctx, cam.X(e.x), cam.Y(e.y), st.shape, st.color); out.events++;
  }
  if (pose) robot(ctx, cam, pose);
  if (scene.rays) { rays(ctx, cam, scene.rays); out.rays = scene.rays.length; }
  out.scale = scaleBar(ctx, cam);
  return out;
}
