// The map: a pan/zoom camera over the arena and the layers drawn on it (world model, truth,
// goals, trajectory, plan, events, robot, sensor rays, labels, metre scale).
const L = 0.226, HEAD = 0.055, R = 0.075; // unit length, head length, unit radius (m)

export const STYLE = {
  known: { fill: "#6b6b6b", stroke: "#333" },
  live: { stroke: "#1d4ed8" }, // a known obstacle added by a live update
  truth: { stroke: "#c0392b" },
  sensed: "rgba(142,68,173,0.75)",
  contact: "#e67e22",
  goal: "#d08a00", reached: "#2a9d2a", removed: "#9a9a9a",
  trail: "#1f77b4", plan: "#0a7f8c", current: "#e0a000",
  robot: "rgba(31,119,180,0.55)", head: "#d62728",
  rayHit: "rgba(214,39,40,0.9)", rayFree: "rgba(214,39,40,0.22)",
  events: {
    replan: { color: "#0a7f8c", shape: "diamond", label: "replan" },
    collision: { color: "#d62728", shape: "cross", label: "collision (bumper)" },
    goal_reached: { color: "#2a9d2a", shape: "star", label: "goal reached" },
    deform: { color: "#8e44ad", shape: "triangle", label: "deformation" },
    dropout: { color: "#7f8c8d", shape: "square", label: "sensor dropout" },
  },
};

const dot = (color, size = 8) => `width:${size}px;height:${size}px;border-radius:50%;background:${color};margin:0 5px`;
export const LEGEND = [
  ["known obstacle", `background:${STYLE.known.fill}`],
  ["obstacle added live", `background:${STYLE.known.fill};box-shadow:inset 0 0 0 2px ${STYLE.live.stroke}`],
  ["sensed occupancy", `background:${STYLE.sensed}`],
  ["contact cells (bumper)", `background:${STYLE.contact}`],
  ["truth (hidden obstacle)", `border:2px dashed ${STYLE.truth.stroke}`],
  ["map: occupied / unknown", `background:linear-gradient(90deg,#333 50%,rgba(160,160,160,0.35) 50%)`],
  ["goal N (its API index) / reached", `border:2px solid ${STYLE.goal};border-radius:50%;box-shadow:inset 0 0 0 2px ${STYLE.reached}`],
  ["robot body (4 units)", `background:${STYLE.robot};border-radius:5px`],
  ["head", dot(STYLE.head)],
  ["trajectory", `border-top:2px solid ${STYLE.trail};height:0`],
  ["plan (hover a step for its primitive)", `border-top:2px dashed ${STYLE.plan};height:0`],
  ["current step", dot(STYLE.current, 10)],
  ["sensor ray: hit / nothing", `border-top:2px solid ${STYLE.rayHit};border-bottom:2px solid ${STYLE.rayFree};height:2px`],
  ...Object.values(STYLE.events).map((e) => [e.label, `color:${e.color};text-align:center;line-height:10px`, e.shape]),
];

const SYMBOLS = { diamond: "◆", cross: "✕", star: "★", triangle: "▲", square: "■" };

/** The legend's HTML. */
export function legendHtml() {
  return LEGEND.map(([label, css, shape]) =>
    `<div><i style="${css}">${shape ? SYMBOLS[shape] : ""}</i>${label}</div>`).join("");
}

/** A camera: world (m) to screen (px), with pan and zoom. A fitted camera (``fitted``) fits
 * its bounds again when the canvas changes size; one the user panned or zoomed keeps its view. */
export class Camera {
  constructor() { this.cx = 0; this.cy = 0; this.scale = 50; this.w = 1; this.h = 1; this.bounds = null; this.fitted = false; }
  X(x) { return (x - this.cx) * this.scale + this.w / 2; }
  Y(y) { return this.h / 2 - (y - this.cy) * this.scale; }
  toWorld(px, py) { return [(px - this.w / 2) / this.scale + this.cx, (this.h / 2 - py) / this.scale + this.cy]; }
  resize(canvas) { this.w = canvas.clientWidth || this.w; this.h = canvas.clientHeight || this.h; }
  fit(b, margin = 0.05) {
    this.bounds = b; this.fitted = true;
    this.cx = (b.xmin + b.xmax) / 2; this.cy = (b.ymin + b.ymax) / 2;
    this.scale = Math.min(this.w / (b.xmax - b.xmin), this.h / (b.ymax - b.ymin)) * (1 - 2 * margin);
  }
  zoomAt(px, py, factor) {
    const [wx, wy] = this.toWorld(px, py);
    this.scale = Math.min(5000, Math.max(2, this.scale * factor));
    const [nx, ny] = this.toWorld(px, py);
    this.cx += wx - nx; this.cy += wy - ny; this.fitted = false;
  }
  pan(dx, dy) { this.cx -= dx / this.scale; this.cy += dy / this.scale; if (dx || dy) this.fitted = false; }
}

/** Wheel zooms about the cursor, dragging pans, a double-click calls ``onFit``; ``onHover``
 * gets the pointer's canvas position (null when it leaves). */
export function attachControls(canvas, cam, onFit, onHover = () => {}) {
  canvas.addEventListener("wheel", (e) => {
    e.preventDefault();
    cam.zoomAt(e.offsetX, e.offsetY, Math.exp(-e.deltaY * 0.0015));
  }, { passive: false });
  let drag = null;
  canvas.addEventListener("pointerdown", (e) => { drag = [e.clientX, e.clientY]; canvas.setPointerCapture(e.pointerId); });
  canvas.addEventListener("pointermove", (e) => {
    onHover({ x: e.offsetX, y: e.offsetY });
    if (!drag) return;
    cam.pan(e.clientX - drag[0], e.clientY - drag[1]); drag = [e.clientX, e.clientY];
  });
  canvas.addEventListener("pointerup", () => { drag = null; });
  canvas.addEventListener("pointerleave", () => onHover(null));
  canvas.addEventListener("dblclick", onFit);
}

function path(ctx, cam, pts, close) {
  ctx.beginPath();
  pts.forEach(([x, y], i) => (i ? ctx.lineTo(cam.X(x), cam.Y(y)) : ctx.moveTo(cam.X(x), cam.Y(y))));
  if (close) ctx.closePath();
}

function corners(o) {
  const c = Math.cos(o.angle || 0), s = Math.sin(o.angle || 0);
  return [[-1, -1], [1, -1], [1, 1], [-1, 1]].map(([dx, dy]) => {
    const lx = dx * o.width / 2, ly = dy * o.height / 2;
    return [o.x + c * lx - s * ly, o.y + s * lx + c * ly];
  });
}

function outline(ctx, cam, o) {
  if (o.type === "circle") { ctx.beginPath(); ctx.arc(cam.X(o.x), cam.Y(o.y), o.radius * cam.scale, 0, 2 * Math.PI); }
  else path(ctx, cam, o.type === "polygon" ? o.points : corners(o), true);
}

/** An obstacle's bounding box on screen [x0, y0, x1, y1] (px). */
function screenBox(cam, o) {
  if (o.type === "circle") {
    const r = o.radius * cam.scale;
    return [cam.X(o.x) - r, cam.Y(o.y) - r, cam.X(o.x) + r, cam.Y(o.y) + r];
  }
  const pts = (o.type === "polygon" ? o.points : corners(o)).map(([x, y]) => [cam.X(x), cam.Y(y)]);
  const xs = pts.map((p) => p[0]), ys = pts.map((p) => p[1]);
  return [Math.min(...xs), Math.min(...ys), Math.max(...xs), Math.max(...ys)];
}

const overlaps = (a, b) => a[0] < b[2] && b[0] < a[2] && a[1] < b[3] && b[1] < a[3];

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

/** The plan: a dashed line from the robot through each action's target, a dot per step (the
 * current one larger). Faded, without dots, once the mission ended. Returns the dots. */
function planLine(ctx, cam, actions, from, current, start, faded) {
  const pts = actions.slice(start).filter((a) => a.target);
  if (!pts.length) return [];
  ctx.save(); ctx.globalAlpha = faded ? 0.3 : 1;
  ctx.strokeStyle = STYLE.plan; ctx.lineWidth = 2; ctx.setLineDash([6, 4]);
  path(ctx, cam, [[from.x, from.y], ...pts.map((a) => [a.target.x, a.target.y])]); ctx.stroke();
  ctx.restore();
  if (faded) return [];
  const dots = [];
  for (const a of pts) {
    const x = cam.X(a.target.x), y = cam.Y(a.target.y), now = a === current;
    ctx.fillStyle = now ? STYLE.current : STYLE.plan;
    ctx.beginPath(); ctx.arc(x, y, now ? 5 : 3, 0, 2 * Math.PI); ctx.fill();
    dots.push({ index: actions.indexOf(a), action: a, x, y, current: now });
  }
  return dots;
}

/** Where a label of ``w`` × 16 px beside the point (x, y) clears every box in ``avoid`` and
 * stays on the canvas: the first free place of a ring of candidates, or null. */
function placeLabel(x, y, w, avoid, width, height) {
  const h = 16, places = [];
  for (const d of [8, 20, 36]) {
    places.push([x + d, y - h / 2], [x - d - w, y - h / 2], [x - w / 2, y - d - h], [x - w / 2, y + d],
      [x + d, y - d - h], [x - d - w, y + d], [x + d, y + d], [x - d - w, y - d - h]);
  }
  for (const [x0, y0] of places) {
    const box = [x0, y0, x0 + w, y0 + h];
    if (box[0] < 0 || box[1] < 0 || box[2] > width || box[3] > height) continue;
    if (!avoid.some((b) => overlaps(box, b))) return box;
  }
  return null;
}

/** Labels of plan steps: the current one, and the one under the pointer. A label never covers
 * an obstacle (known, added live, sensed, felt, or hidden when the truth is shown), a goal or
 * another label; where no place is free it is left out (the plan list names every step). */
function stepLabels(ctx, cam, dots, hover, avoid) {
  const near = hover ? dots.filter((d) => Math.hypot(d.x - hover.x, d.y - hover.y) < 10) : [];
  const under = near.sort((a, b) => Math.hypot(a.x - hover.x, a.y - hover.y) - Math.hypot(b.x - hover.x, b.y - hover.y))[0];
  const chosen = [...dots.filter((d) => d.current), ...(under && !under.current ? [under] : [])];
  ctx.save(); ctx.font = "11px ui-monospace, monospace"; ctx.textBaseline = "middle";
  const out = [];
  for (const d of chosen) {
    const text = `${d.index + 1} ${primitiveOf(d.action)}`, w = ctx.measureText(text).width + 6;
    const box = placeLabel(d.x, d.y, w, avoid, cam.w, cam.h);
    if (!box) continue;
    avoid.push(box); out.push({ text, box, step: d.index + 1, hovered: d === under });
    const nx = Math.max(box[0], Math.min(d.x, box[2])), ny = Math.max(box[1], Math.min(d.y, box[3]));
    if (Math.hypot(nx - d.x, ny - d.y) > 9) { // a leader from the dot to a label set apart
      ctx.strokeStyle = d.current ? STYLE.current : STYLE.plan; ctx.lineWidth = 1;
      ctx.beginPath(); ctx.moveTo(d.x, d.y); ctx.lineTo(nx, ny); ctx.stroke();
    }
    ctx.fillStyle = "rgba(255,255,255,0.92)"; ctx.fillRect(box[0], box[1], w, 16);
    ctx.strokeStyle = d.current ? STYLE.current : STYLE.plan; ctx.lineWidth = 1; ctx.strokeRect(box[0], box[1], w, 16);
    ctx.fillStyle = d.current ? "#8a5a00" : STYLE.plan; ctx.fillText(text, box[0] + 3, box[1] + 8);
  }
  ctx.restore();
  return out;
}

/** The goals above everything but labels, each with a white halo and its API index. */
function goalMarks(ctx, cam, goals) {
  const out = [];
  goals.forEach((g, index) => {
    if (!g) return;
    const x = cam.X(g.x), y = cam.Y(g.y), r = Math.max(g.tolerance * cam.scale, 6);
    const color = g.removed ? STYLE.removed : g.reached ? STYLE.reached : STYLE.goal;
    ctx.save();
    ctx.beginPath(); ctx.arc(x, y, r, 0, 2 * Math.PI);
    ctx.strokeStyle = "white"; ctx.lineWidth = 5; ctx.stroke();
    ctx.setLineDash(g.removed ? [3, 3] : []); ctx.strokeStyle = color; ctx.lineWidth = 2.5; ctx.stroke();
    ctx.setLineDash([]);
    ctx.beginPath(); ctx.arc(x, y, 2.5, 0, 2 * Math.PI); ctx.fillStyle = color; ctx.fill();
    const text = `goal ${index}${g.removed ? " (removed)" : ""}`;
    ctx.font = "bold 11px system-ui"; ctx.lineWidth = 3; ctx.strokeStyle = "white";
    ctx.strokeText(text, x + r + 3, y - r - 2); ctx.fillText(text, x + r + 3, y - r - 2);
    const w = ctx.measureText(text).width;
    ctx.restore();
    out.push({ index, x: g.x, y: g.y, reached: !!g.reached, removed: !!g.removed, box: [x - r, Math.min(y - r, y - r - 14), Math.max(x + r, x + r + 3 + w), y + r] });
  });
  return out;
}

/** An occupancy-grid map's cells (a bitmap, row 0 the top) in the world: its lower-left
 * corner at the map's origin, turned by its yaw (the canvas's y runs down: the turn is -yaw). */
function drawMap(ctx, cam, map) {
  const { origin, resolution, width, height } = map.meta;
  ctx.save();
  ctx.imageSmoothingEnabled = false;
  ctx.translate(cam.X(origin[0]), cam.Y(origin[1]));
  ctx.rotate(-origin[2]);
  const s = resolution * cam.scale;
  if (!map.known) {
    ctx.globalAlpha = 0.55; // the truth, lighter than what the planner knows
  }
  ctx.drawImage(map.bitmap, 0, -height * s, width * s, height * s);
  if (!map.known) {
    ctx.globalAlpha = 1; ctx.setLineDash([5, 4]); ctx.lineWidth = 2; ctx.strokeStyle = STYLE.truth.stroke;
    ctx.strokeRect(0, -height * s, width * s, height * s);
  }
  ctx.restore();
}

/** Draw everything of ``scene`` on the canvas; returns what was drawn (for tests, as
 * ``window.viewer.drawn``: label boxes, obstacle boxes, goals, ... in canvas pixels). */
export function drawScene(canvas, cam, scene) {
  const ctx = canvas.getContext("2d"), dpr = window.devicePixelRatio || 1;
  const w = canvas.clientWidth, h = canvas.clientHeight;
  if (canvas.width !== Math.round(w * dpr) || canvas.height !== Math.round(h * dpr)) {
    canvas.width = Math.round(w * dpr); canvas.height = Math.round(h * dpr);
  }
  const resized = w !== cam.w || h !== cam.h;
  cam.w = w; cam.h = h;
  if (resized && cam.fitted && cam.bounds) cam.fit(cam.bounds); // the whole arena stays in view
  ctx.setTransform(dpr, 0, 0, dpr, 0, 0); ctx.clearRect(0, 0, w, h);
  const out = {
    labels: [], labelBoxes: [], obstacleBoxes: [], goals: [], obstacles: [], dots: [], maps: [],
    planFaded: false, scale: "", events: 0, rays: 0, sensed: 0, view: { w, h, scale: cam.scale, fitted: cam.fitted },
  };
  const m = scene.mission;
  if (!m) return out;
  const b = m.request.bounds;
  ctx.strokeStyle = "#999"; ctx.lineWidth = 1;
  ctx.strokeRect(cam.X(b.xmin), cam.Y(b.ymax), (b.xmax - b.xmin) * cam.scale, (b.ymax - b.ymin) * cam.scale);
  const onScreen = (box) => box[2] >= 0 && box[0] <= w && box[3] >= 0 && box[1] <= h;
  for (const map of scene.maps || []) {
    if (!map.known && !scene.truth) continue; // a hidden map is the truth: shown with it
    drawMap(ctx, cam, map);
    out.maps.push({ id: map.id, known: map.known });
  }
  for (const known of scene.obstacles || []) {
    const o = known.obstacle;
    outline(ctx, cam, o); ctx.fillStyle = STYLE.known.fill; ctx.fill();
    ctx.strokeStyle = known.source === "live" ? STYLE.live.stroke : STYLE.known.stroke;
    ctx.lineWidth = known.source === "live" ? 2.5 : 1; ctx.stroke();
    out.obstacles.push(known.id);
    out.obstacleBoxes.push({ id: known.id, box: screenBox(cam, o) });
  }
  const cell = (scene.world.resolution || 0.05) * cam.scale;
  const inside = ([x, y]) => x >= b.xmin && x <= b.xmax && y >= b.ymin && y <= b.ymax;
  const cellBox = ([x, y]) => [cam.X(x) - cell / 2, cam.Y(y) - cell / 2, cam.X(x) + cell / 2, cam.Y(y) + cell / 2];
  ctx.fillStyle = STYLE.sensed;
  for (const c of scene.world.sensed.filter(inside)) {
    const box = cellBox(c); ctx.fillRect(box[0], box[1], cell, cell); out.sensed++;
    if (onScreen(box)) out.obstacleBoxes.push({ id: "sensed", box });
  }
  for (const c of scene.world.contacts) {
    marker(ctx, cam.X(c[0]), cam.Y(c[1]), "square", STYLE.contact, Math.max(2, cell / 2));
    out.obstacleBoxes.push({ id: "contact", box: cellBox(c) });
  }
  if (scene.truth) {
    ctx.save(); ctx.setLineDash([5, 4]); ctx.lineWidth = 2; ctx.strokeStyle = STYLE.truth.stroke;
    (m.request.obstacles || []).forEach((o, i) => {
      if (o.known) return;
      outline(ctx, cam, o); ctx.stroke(); out.obstacleBoxes.push({ id: `hidden-${i}`, box: screenBox(cam, o) });
    });
    ctx.restore();
  }
  if (scene.trail.length) {
    ctx.strokeStyle = STYLE.trail; ctx.lineWidth = 2; path(ctx, cam, scene.trail.map((r) => [r[1], r[2]])); ctx.stroke();
  }
  const pose = scene.pose || m.pose;
  const dots = pose ? planLine(ctx, cam, scene.plan, scene.planFrom || pose, scene.current, scene.planStart || 0, scene.ended) : [];
  out.dots = dots.map((d) => ({ step: d.index + 1, x: d.x, y: d.y, current: d.current }));
  out.planFaded = !!scene.ended && scene.plan.length > 0;
  for (const e of scene.events) {
    const st = STYLE.events[e.kind];
    if (!st || e.x === undefined) continue;
    marker(ctx, cam.X(e.x), cam.Y(e.y), st.shape, st.color); out.events++;
  }
  if (pose) robot(ctx, cam, pose);
  if (scene.rays) { rays(ctx, cam, scene.rays); out.rays = scene.rays.length; }
  out.goals = goalMarks(ctx, cam, scene.goals || []);
  const avoid = [...out.obstacleBoxes.map((o) => o.box), ...out.goals.map((g) => g.box)];
  out.labelBoxes = stepLabels(ctx, cam, dots, scene.hover, avoid);
  out.labels = out.labelBoxes.map((l) => l.text);
  out.scale = scaleBar(ctx, cam);
  return out;
}
