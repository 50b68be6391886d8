// The viewer's data and panels: missions list, live websocket, world model, tree, plan, replay.
import { Camera, attachControls, drawScene, legendHtml, primitiveOf } from "/static/map.js";

const $ = (id) => document.getElementById(id);
const TERMINAL = ["succeeded", "failed", "cancelled"];
const STATUSES = ["queued", "planning", "executing", "replanning", "learning", "paused", "cancelling", "succeeded", "failed", "cancelled"];
// Reasons worth a user's eye in the status bar; the others (which worker took a mission, an
// empty reason after a replan) stay in the transitions.
const REASONED = new Set(["replanning", "learning", "paused", "cancelling", ...TERMINAL]);
const KEY = "screwsnake-api-key";
const WORLD_POLL_MS = 2000, LIST_POLL_MS = 3000, PENDING_MS = 5000;

// Everything the map and panels show; ``window.viewer`` lets the browser tests read it
// (``drawn`` is what the canvas drew last: label and obstacle boxes, goals, ...).
const state = {
  mission: null, status: "", reason: "", socket: null, live: false,
  pose: null, trail: [], plan: [], planVersion: 0, action: "", rays: null, tree: null,
  maps: [], // the mission's occupancy-grid maps: {id, known, meta, bitmap}
  goals: [], obstacles: [], // what the map draws: live, the current ones; in a replay, those of the slider's time
  world: { sensed: [], contacts: [], resolution: 0.05 }, events: [],
  replay: null, replayT: null, planAt: null, planFrom: null, truth: false, drawn: null,
  features: { pause: false, resume: false }, pending: null, hover: null,
};
window.viewer = state;
const cam = new Camera();
let selecting = 0; // the latest select() call: older ones stop when a newer one starts

// -- API ----------------------------------------------------------------------------------------
function showError(text) { $("error").textContent = text; $("error").hidden = !text; }

async function api(path, options = {}) {
  const headers = { ...(options.headers || {}) };
  const key = sessionStorage.getItem(KEY);
  if (key) headers.Authorization = `Bearer ${key}`;
  const r = await fetch(path, { ...options, headers });
  if (r.status === 401) {
    showError("401: this server needs an API key for that — enter it under “API key” (left).");
    throw new Error("unauthorized");
  }
  if (!r.ok) {
    let detail = r.statusText;
    try { detail = (await r.json()).detail || detail; } catch { /* not JSON */ }
    showError(`${r.status}: ${detail}`);
    throw new Error(detail);
  }
  return r.json();
}

const post = (path, body) => api(path, {
  method: "POST", headers: { "Content-Type": "application/json" }, body: body ? JSON.stringify(body) : undefined,
});

// -- units --------------------------------------------------------------------------------------
const cm = (v) => `${(Number(v) * 100).toFixed(1)} cm`;
const secs = (v) => `${Number(v).toFixed(1)} s`;
const point = (p) => `(${Number(p[0]).toFixed(2)}, ${Number(p[1]).toFixed(2)}) m`;
const radians = (list) => `[${list.map((v) => Number(v).toFixed(2)).join(", ")}] rad`;

// -- missions list ------------------------------------------------------------------------------
function age(iso) {
  const s = Math.max(0, (Date.now() - Date.parse(iso)) / 1000);
  if (s < 60) return `${s.toFixed(0)} s ago`;
  if (s < 3600) return `${(s / 60).toFixed(0)} min ago`;
  if (s < 86400) return `${(s / 3600).toFixed(0)} h ago`;
  return `${(s / 86400).toFixed(0)} d ago`;
}

const esc = (s) => String(s).replace(/[&<>"]/g, (c) => ({ "&": "&amp;", "<": "&lt;", ">": "&gt;", '"': "&quot;" })[c]);
const pursued = (goals) => goals.filter((g) => !g.removed);

async function loadMissions() {
  const status = $("filter").value;
  const page = await api(`/missions?limit=50${status ? `&status=${status}` : ""}`);
  $("total").textContent = `${page.items.length} of ${page.total}`;
  $("missions").innerHTML = page.items.map((m) => {
    const goals = pursued(m.goals), reached = goals.filter((g) => g.reached).length;
    const sel = state.mission && state.mission.id === m.id ? "selected" : "";
    return `<li data-id="${m.id}" data-status="${m.status}" class="${sel}" title="${esc(m.reason || m.status)}">` +
      `<span class="name">${esc(m.name)}</span><span class="st ${m.status}">${m.status}</span>` +
      `<span class="meta">goals ${reached}/${goals.length} · replans ${m.replans} · ${age(m.created_at)} · ${m.id.slice(0, 8)}</span></li>`;
  }).join("");
  for (const li of $("missions").querySelectorAll("li")) li.onclick = () => select(li.dataset.id);
  return page.items;
}

// -- panels -------------------------------------------------------------------------------------
const actionText = (a) => `(${[a.name, ...a.args].join(" ")})`;
/** The action running now: live, the one the state frames name; in a replay, the one whose
 * slot (plan time + the durations before it) holds the slider's time. */
function currentAction() {
  if (state.replayT === null) return state.plan.find((a) => actionText(a) === state.action) || null;
  let t = state.planAt;
  if (t === null) return null;
  for (const a of state.plan) {
    if (a.duration === null || a.duration === undefined) return null;
    t += a.duration;
    if (state.replayT < t) return a;
  }
  return null;
}

function goalTitle(g, i) {
  if (g.removed) return `goal ${i}: removed at ${secs(g.removed_at || 0)}`;
  const where = `goal ${i} at ${point([g.x, g.y])}, tolerance ${cm(g.tolerance)}`;
  return g.reached ? `${where}: reached at ${secs(g.reached_at)}, ${cm(g.error)} off` : `${where}: not reached`;
}

function setStatus() {
  const m = state.mission;
  if (!m) return;
  const goals = state.goals, shown = pursued(goals);
  const marks = goals.map((g, i) => (g.removed ? "" : `<span title="${esc(goalTitle(g, i))}">${g.reached ? "✓" : "○"}</span>`)).join("");
  const t = state.pose && state.pose.t !== undefined ? state.pose.t : m.model_time;
  // in a replay, the replans made by the slider's time
  const replans = state.replay ? state.replay.replans.filter((r) => r.at <= t).length : m.replans;
  const before = state.replay && state.replayT !== null && !atReplayEnd(); // a replay before the end
  const reason = state.reason && REASONED.has(state.status)
    ? ` · <span id="reason">${before ? "at the end: " : ""}${esc(state.reason)}</span>` : "";
  const pending = state.pending ? ` · <span id="pending">${state.pending} requested…</span>` : "";
  $("status").innerHTML = `<b>${esc(m.name)}</b> <span class="st ${state.status}" id="mission-status">${state.status}</span> ` +
    `t = ${secs(t)} · <span id="goals">goals ${shown.filter((g) => g.reached).length}/${shown.length}</span> ${marks} · replans ${replans}${reason}${pending}`;
  $("status").title = $("status").textContent; // the whole line, where the bar cuts it
  const ended = TERMINAL.includes(state.status);
  $("cancel").hidden = ended || state.status === "cancelling";
  $("pause").hidden = ended || !state.features.pause || state.status === "paused";
  $("resume").hidden = ended || !state.features.resume || state.status !== "paused";
  for (const verb of ["cancel", "pause", "resume"]) $(verb).disabled = state.pending !== null;
}

function showPlan(actions, version) {
  state.plan = actions || [];
  if (version !== undefined) state.planVersion = version;
  $("plan-version").textContent = state.planVersion ? `v${state.planVersion}, ${state.plan.length} actions` : "";
  const cur = currentAction();
  $("plan").innerHTML = state.plan.map((a) =>
    `<li class="${a === cur ? "current" : ""}" title="${esc(actionText(a))}">${esc(primitiveOf(a))}</li>`).join("");
  const li = $("plan").querySelector("li.current"); // keep the running action in view
  if (li) $("plan").scrollTop = li.offsetTop - $("plan").offsetTop - 30;
}

/** A node as the snapshot reports it: its status colours it; its feedback is shown only while
 * the node takes part in the tick (an INVALID node was not ticked: what it last said is old). */
function treeHtml(node) {
  const leaf = !node.children || !node.children.length;
  const current = leaf && node.status === "RUNNING" ? " current" : "";
  const fb = node.feedback && node.status !== "INVALID" ? ` <span class="fb">${esc(node.feedback)}</span>` : "";
  const kids = leaf ? "" : `<ul>${node.children.map(treeHtml).join("")}</ul>`;
  return `<li><span class="node ${node.status}${current}" data-status="${node.status}">${esc(node.name)}${fb}</span>${kids}</li>`;
}

/** The tree panel shows one snapshot and says which: live, its model time; after the end, the
 * last one (and, at an earlier replay time, that it is the end's, greyed). */
function showTree(tree, note, stale = false) {
  state.tree = tree && tree.name ? tree : null;
  $("tree").innerHTML = state.tree ? `<ul>${treeHtml(state.tree)}</ul>` : '<p class="muted">No tree snapshot yet.</p>';
  $("tree").classList.toggle("stale", !!state.tree && stale);
  $("tree-time").textContent = state.tree ? note : "";
}

function updateText(e) {
  const d = e.detail || {};
  if (e.update === "add_goal") return `goal ${d.goal} added at ${point([d.x, d.y])}`;
  if (e.update === "remove_goal") return `goal ${d.goal} removed`;
  if (e.update === "add_obstacle") return `a known ${d.obstacle ? d.obstacle.type : "obstacle"} added`;
  if (e.update === "resume") return `resumed (paused at ${secs(d.paused_at || 0)})`;
  if (e.update === "pause") return "paused";
  return `${e.update}${d.reason ? `: ${d.reason}` : ""}`;
}

/** An event as a line with units: metres, centimetres for goal errors, model seconds. */
function eventText(e) {
  const t = secs(e.t);
  switch (e.kind) {
    case "goal_reached": return `${t} goal ${e.goal} reached, ${cm(e.error)} off`;
    case "replan": {
      const how = e.status && e.status !== "solved" ? `: ${e.status}` : "";
      const ms = e.latency_ms !== undefined ? `, planned in ${Math.round(e.latency_ms)} ms` : "";
      return `${t} replan (${e.trigger})${how}${ms}`;
    }
    case "collision": return `${t} collision: unit ${e.part}, ${e.side} side${Array.isArray(e.at) ? ` at ${point(e.at)}` : ""}`;
    case "deform": return `${t} deformation to ${radians(e.joints || [])}${e.shape ? ` (${e.shape})` : ""}`;
    case "dropout": return `${t} dropout of ${(e.sensors || []).join(", ")} for ${secs(e.duration || 0)}`;
    case "shape_change": return `${t} shape ${e.previous} → ${e.shape}`;
    case "update": return `${t} update: ${updateText(e)}`;
    case "recovery": return `${t} recovery: ${e.recovery} (${e.because}): ${(e.moves || []).join(", ") || "no motion"}`;
    case "recovery_done": return `${t} recovery ${e.recovery}: ${e.outcome}`;
    default: {
      const skip = new Set(["t", "kind", "x", "y", "type"]);
      const rest = Object.entries(e).filter(([k]) => !skip.has(k)).map(([k, v]) => `${k}=${typeof v === "object" ? JSON.stringify(v) : v}`);
      return `${t} ${e.kind} ${rest.join(" ")}`;
    }
  }
}

function showEvents() {
  const t = state.replayT;
  const shown = state.events.filter((e) => e.kind !== "obstacle_sensed");
  $("events").innerHTML = shown.map((e) =>
    `<li class="${t !== null && e.t > t ? "future" : ""}">${esc(eventText(e))}</li>`).join("");
}

// -- positions along the trajectory (rows [t, x, y, psi, phi1, phi2, phi3]) ---------------------
function rowAt(rows, t) {
  if (!rows.length) return null;
  let lo = 0, hi = rows.length - 1;
  if (t <= rows[0][0]) return rows[0];
  if (t >= rows[hi][0]) return rows[hi];
  while (hi - lo > 1) { const mid = (lo + hi) >> 1; if (rows[mid][0] <= t) lo = mid; else hi = mid; }
  const a = rows[lo], b = rows[hi], f = (t - a[0]) / (b[0] - a[0] || 1);
  return a.map((v, i) => v + (b[i] - v) * f);
}

const poseOf = (row) => ({ t: row[0], x: row[1], y: row[2], psi: row[3], joints: row.slice(4, 7) });

/** Events placed on the map: a contact where it touched, the rest where the robot was. */
function placeEvent(e, rows) {
  if (e.kind === "collision" && Array.isArray(e.at)) return { ...e, x: e.at[0], y: e.at[1] };
  const row = rowAt(rows, e.t);
  return row ? { ...e, x: row[1], y: row[2] } : e;
}

// -- what the mission knows: goals and known obstacles -------------------------------------------
/** The server's lists (``GET /world`` or the mission), keeping what live events added since
 * it last saved the mission's state (it saves about once a second). */
function mergeKnown(goals, obstacles) {
  const local = state.goals;
  const merged = goals.map((g, i) => {
    const mine = local[i];
    if (!mine) return g;
    // a goal_reached or remove event may be newer than the saved state
    return { ...g, ...(mine.reached && !g.reached ? { reached: true, error: mine.error, reached_at: mine.reached_at } : {}),
      ...(mine.removed && !g.removed ? { removed: true, removed_at: mine.removed_at } : {}) };
  });
  state.goals = [...merged, ...local.slice(goals.length)];
  const ids = new Set(obstacles.map((o) => o.id));
  state.obstacles = [...obstacles, ...state.obstacles.filter((o) => !ids.has(o.id))];
}

/** A live update as it happens: the map shows it at once (the next poll confirms it). */
function applyUpdate(e) {
  const d = e.detail || {};
  if (e.update === "add_goal" && d.goal !== undefined) {
    state.goals[d.goal] = { x: d.x, y: d.y, tolerance: 0.1, reached: false, source: "live", added_at: e.t, ...(state.goals[d.goal] || {}) };
  } else if (e.update === "remove_goal" && state.goals[d.goal]) {
    state.goals[d.goal] = { ...state.goals[d.goal], removed: true, removed_at: e.t };
  } else if (e.update === "add_obstacle" && d.obstacle) {
    const n = state.obstacles.filter((o) => o.source === "live").length;
    state.obstacles.push({ id: `live-${n}`, source: "live", added_at: e.t, obstacle: d.obstacle });
  }
}

/** Goals as they were at model time ``t``: those added by then, reached only if by then. */
function goalsAt(goals, t) {
  return goals.map((g) => (g.added_at > t ? null : {
    ...g, reached: g.reached && g.reached_at !== null && g.reached_at <= t, removed: g.removed && g.removed_at !== null && g.removed_at <= t,
  }));
}

/** The sensed and contact cells at model time ``t``: every change up to ``t`` applied. */
function worldAt(changes, t) {
  const layers = { sensed: new Map(), contacts: new Map() };
  for (const c of changes) {
    if (c.t > t) break;
    for (const [name, cells] of Object.entries(layers)) {
      const change = c[name];
      if (!change) continue;
      for (const [x, y] of change.removed) cells.delete(`${x},${y}`);
      for (const [x, y] of change.added) cells.set(`${x},${y}`, [x, y]);
    }
  }
  return { sensed: [...layers.sensed.values()], contacts: [...layers.contacts.values()] };
}

// -- replay -------------------------------------------------------------------------------------
function setReplayTime(t) {
  const r = state.replay;
  if (!r || !r.trajectory.length) return;
  state.replayT = t;
  const rows = r.trajectory, end = rows[rows.length - 1][0];
  state.trail = rows.filter((row) => row[0] <= t);
  state.pose = poseOf(rowAt(rows, t));
  state.trail.push([t, state.pose.x, state.pose.y]);
  const version = r.plans.filter((p) => p.at === null || p.at <= t).pop();
  state.planAt = version && version.at !== null ? version.at : null;
  // The plan is drawn from where the robot was when it was made.
  const made = state.planAt === null ? null : rowAt(rows, state.planAt);
  state.planFrom = made ? poseOf(made) : null;
  showPlan(version ? version.actions : [], version ? version.version : 0);
  // The world model, goals and obstacles as they were then (a mission stored before the world
  // model's changes were kept has only its last model).
  if (r.world && r.world.length) state.world = { ...state.world, ...worldAt(r.world, t) };
  state.goals = goalsAt(r.goals && r.goals.length ? r.goals : state.mission.goals, t);
  state.obstacles = (r.obstacles || state.mission.obstacles || []).filter((o) => o.added_at <= t);
  $("slider-t").textContent = secs(t);
  showEvents();
  if (state.tree) {
    const atEnd = t >= end - 1e-6;
    showTree(state.tree, atEnd ? "last snapshot" : `as it ended at ${secs(end)}`, !atEnd);
  }
  setStatus();
}

async function loadReplay(id, token) {
  const r = await api(`/missions/${id}/replay`);
  if (token !== selecting) return;
  const rows = r.trajectory;
  const events = [...r.events];
  // Replans come from the store too (older missions kept no events in their state).
  if (!events.some((e) => e.kind === "replan")) for (const p of r.replans) events.push({ t: p.at, kind: "replan", trigger: p.trigger });
  events.sort((a, b) => a.t - b.t);
  state.replay = r;
  state.events = events.map((e) => placeEvent(e, rows));
  if (!rows.length) { $("replay").hidden = true; showEvents(); return; }
  const end = rows[rows.length - 1][0];
  Object.assign($("slider"), { min: 0, max: end, step: Math.max(0.25, end / 2000) });
  $("slider").value = end;
  $("replay").hidden = false;
  setReplayTime(end);
}

// -- live ---------------------------------------------------------------------------------------
async function loadWorld(id, token) {
  const w = await api(`/missions/${id}/world`);
  if (token !== selecting || state.replayT !== null) return;
  state.world = { sensed: w.sensed, contacts: w.contacts, resolution: w.resolution || 0.05 };
  mergeKnown(w.goals || [], w.obstacles || []);
  setStatus();
}

/** The path before this page connected (the server keeps a running mission's path). */
async function loadTrail(id, token) {
  const r = await api(`/missions/${id}/trajectory`);
  if (token !== selecting || state.replayT !== null) return;
  const first = state.trail.length ? state.trail[0][0] : Infinity;
  state.trail = [...r.points.filter((row) => row[0] < first), ...state.trail];
}

/** The websocket is the one source of the status shown: its snapshot, then its status events
 * (an answer to Pause or Resume says only that the request was taken). */
function connect(id, token) {
  const ws = new WebSocket(`${location.protocol === "https:" ? "wss" : "ws"}://${location.host}/missions/${id}/ws`);
  state.socket = ws;
  ws.onmessage = (msg) => {
    if (token !== selecting) return;
    const f = JSON.parse(msg.data);
    if (f.type === "snapshot") {
      state.mission = f.mission; state.status = f.mission.status; state.reason = f.mission.reason;
      mergeKnown(f.mission.goals, f.mission.obstacles || []);
      showPlan(f.plan.actions, f.plan.version);
    } else if (f.type === "state") {
      state.pose = { ...f.pose, t: f.t }; state.rays = f.sensors && f.sensors.rays ? f.sensors.rays : null;
      state.trail.push([f.t, f.pose.x, f.pose.y]); state.action = f.action || "";
      state.mission.model_time = f.t;
      showTree(f.tree, `t = ${secs(f.t)}`); showPlan(state.plan);
    } else if (f.type === "plan") showPlan(f.actions, f.version);
    else if (f.type === "event") {
      if (f.kind === "status") {
        state.status = f.status; state.reason = f.reason || ""; state.pending = null;
        const badge = document.querySelector(`#missions li[data-id="${id}"] .st`); // list polls slower
        if (badge) { badge.textContent = f.status; badge.className = `st ${f.status}`; }
      } else if (f.kind === "goal_reached" && state.goals[f.goal]) {
        state.goals[f.goal] = { ...state.goals[f.goal], reached: true, error: f.error, reached_at: f.t };
      } else if (f.kind === "replan") state.mission.replans += 1;
      else if (f.kind === "update") applyUpdate(f);
      if (f.kind !== "status") {
        const e = { ...f, t: f.t !== undefined ? f.t : f.at };
        const p = state.pose;
        state.events.push(e.kind === "collision" && Array.isArray(e.at) ? { ...e, x: e.at[0], y: e.at[1] } : { ...e, x: p && p.x, y: p && p.y });
        showEvents();
      }
    } else if (f.type === "end") {
      state.status = f.status; state.reason = f.reason; state.live = false; state.rays = null; state.pending = null;
      finish(id, token);
    }
    setStatus();
  };
}

async function finish(id, token) {
  const m = await api(`/missions/${id}`);
  if (token !== selecting) return;
  state.mission = m; state.status = m.status; state.reason = m.reason;
  mergeKnown(m.goals, m.obstacles || []);
  await Promise.all([loadWorld(id, token), loadTreeOnce(id, token)]);
  await loadReplay(id, token);
  loadMissions().catch(() => {});
  setStatus();
}

/** The mission's maps (known, and hidden for "truth"): each one's parameters and its cells as
 * a bitmap (fetched with the key, if any: an <img> could not send it). */
async function loadMaps(m, token) {
  const entries = (m.request.maps || []).filter((e) => e.id);
  const maps = await Promise.all(entries.map(async (e) => {
    const meta = await api(`/maps/${e.id}?image=false`);
    const headers = {};
    const key = sessionStorage.getItem(KEY);
    if (key) headers.Authorization = `Bearer ${key}`;
    const r = await fetch(`/maps/${e.id}/cells.png`, { headers });
    if (!r.ok) throw new Error(`map ${e.id}: ${r.status}`);
    const bitmap = await createImageBitmap(await r.blob());
    return { id: e.id, known: e.known !== false, meta, bitmap };
  }));
  if (token === selecting) state.maps = maps;
}

async function loadTreeOnce(id, token) {
  const tree = await api(`/missions/${id}/tree`);
  if (token !== selecting || !tree || !tree.name) return;
  showTree(tree, "last snapshot");
}

// -- selection ----------------------------------------------------------------------------------
async function select(id) {
  const token = ++selecting;
  if (state.socket) state.socket.close();
  // Everything of the previous mission goes: sensed cells, events, trail, plan, tree, replay.
  Object.assign(state, {
    socket: null, pose: null, trail: [], plan: [], planVersion: 0, action: "", rays: null, reason: "",
    world: { sensed: [], contacts: [], resolution: 0.05 }, events: [], replay: null, replayT: null, live: false,
    planAt: null, planFrom: null, goals: [], obstacles: [], pending: null, maps: [],
  });
  showTree(null); showPlan([]); showEvents(); $("replay").hidden = true;
  const m = await api(`/missions/${id}`);
  if (token !== selecting) return;
  state.mission = m; state.status = m.status; state.reason = m.reason;
  mergeKnown(m.goals, m.obstacles || []);
  loadMaps(m, token).catch(() => {});
  fitMission();
  for (const li of $("missions").querySelectorAll("li")) li.classList.toggle("selected", li.dataset.id === id);
  setStatus();
  if (TERMINAL.includes(m.status)) {
    const plan = await api(`/missions/${id}/plan`);
    if (token === selecting) showPlan(plan.actions, plan.version);
    await finish(id, token);
  } else {
    state.live = true;
    connect(id, token);
    loadWorld(id, token).catch(() => {});
    loadTrail(id, token).catch(() => {});
    // Events from before we connected (the stored state, about a second old), then the live ones.
    api(`/missions/${id}/replay`).then((r) => {
      if (token !== selecting) return;
      const first = state.events.length ? state.events[0].t : Infinity;
      state.events = [...r.events.filter((e) => e.t < first), ...state.events];
      showEvents();
    }).catch(() => {});
  }
}

// -- controls -----------------------------------------------------------------------------------
$("key-form").onsubmit = (e) => {
  e.preventDefault();
  const key = $("api-key").value.trim();
  if (key) sessionStorage.setItem(KEY, key); else sessionStorage.removeItem(KEY);
  showError("");
};
$("api-key").value = sessionStorage.getItem(KEY) || "";

$("post").onsubmit = async (e) => {
  e.preventDefault();
  try {
    const body = await api(`/examples/${$("example").value}`);
    body.speed = Number($("speed").value) || 0;
    const m = await post("/missions", body);
    showError("");
    await select(m.id);
    loadMissions().catch(() => {});
  } catch { /* shown by api() */ }
};

// A request is shown as requested until the websocket reports the status it led to (or it
// failed, or nothing came within PENDING_MS); its answer never sets the status itself.
for (const verb of ["cancel", "pause", "resume"]) {
  $(verb).onclick = async () => {
    if (!state.mission || state.pending) return;
    const mission = state.mission.id;
    state.pending = verb; setStatus();
    const clear = () => { if (state.mission && state.mission.id === mission && state.pending === verb) { state.pending = null; setStatus(); } };
    setTimeout(clear, PENDING_MS);
    try {
      await post(`/missions/${mission}/${verb}`);
      showError("");
    } catch { clear(); /* shown by api() */ }
  };
}

$("filter").onchange = () => loadMissions().catch(() => {});
$("truth").onchange = () => { state.truth = $("truth").checked; };
function fitMission() {
  if (!state.mission) return;
  cam.resize($("arena"));
  cam.fit(state.mission.request.bounds);
}
$("fit").onclick = fitMission;
$("slider").oninput = () => setReplayTime(Number($("slider").value));
attachControls($("arena"), cam, fitMission, (p) => { state.hover = p; });
$("legend").innerHTML = legendHtml();

/** The plan is drawn from the robot through the actions not yet done (the trail shows those
 * done); in a replay whose current step is unknown, all of it from where it was made. */
function remainingFrom() {
  const i = state.plan.indexOf(currentAction());
  return i < 0 ? 0 : i;
}

/** A finished mission at the end of its replay: its last plan is done (drawn faded). */
function atReplayEnd() {
  const r = state.replay;
  if (!r || !r.trajectory.length || state.replayT === null) return false;
  return state.replayT >= r.trajectory[r.trajectory.length - 1][0] - 1e-6;
}

function frame() {
  state.drawn = drawScene($("arena"), cam, {
    mission: state.mission, goals: state.goals, obstacles: state.obstacles, world: state.world, maps: state.maps,
    truth: state.truth, trail: state.trail, pose: state.pose, plan: state.plan, current: currentAction(),
    rays: state.rays, planFrom: state.replayT === null || currentAction() ? null : state.planFrom, planStart: remainingFrom(),
    events: state.replayT === null ? state.events : state.events.filter((e) => e.t <= state.replayT),
    ended: atReplayEnd(), hover: state.hover,
  });
  requestAnimationFrame(frame);
}

async function start() {
  // Pause/resume buttons appear only when the API offers them; the status filter lists the
  // statuses the API has.
  try {
    const spec = await fetch("/openapi.json").then((r) => r.json());
    state.features.pause = "/missions/{mission_id}/pause" in spec.paths;
    state.features.resume = "/missions/{mission_id}/resume" in spec.paths;
    const known = ((spec.components || {}).schemas || {}).MissionStatus;
    if (known && known.enum) STATUSES.splice(0, STATUSES.length, ...known.enum);
  } catch { /* no schema: no buttons */ }
  $("filter").innerHTML = '<option value="">all</option>' + STATUSES.map((s) => `<option>${esc(s)}</option>`).join("");
  api("/examples").then(({ items }) => {
    $("example").innerHTML = items.map((n) => `<option>${esc(n)}</option>`).join("");
  }).catch(() => {});
  const items = await loadMissions().catch(() => []);
  if (items.length && !state.mission) await select(items[0].id); // open on the latest mission
  setInterval(() => loadMissions().catch(() => {}), LIST_POLL_MS);
  setInterval(() => { if (state.live && state.mission) loadWorld(state.mission.id, selecting).catch(() => {}); }, WORLD_POLL_MS);
  requestAnimationFrame(frame);
}

start();
