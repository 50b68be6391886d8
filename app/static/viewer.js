// The viewer's data and panels: missions list, live websocket, world model, tree, plan, replay.
import { Camera, attachControls, drawScene, legendHtml, primitiveOf } from "/static/map.js";

const $ = (id) => document.getElementById(id);
const TERMINAL = ["succeeded", "failed", "cancelled"];
const KEY = "screwsnake-api-key";
const WORLD_POLL_MS = 2000, LIST_POLL_MS = 3000;

// Everything the map and panels show; ``window.viewer`` lets the browser tests read it.
const state = {
  mission: null, status: "", reason: "", socket: null, live: false,
  pose: null, trail: [], plan: [], planVersion: 0, action: "", rays: null, tree: null,
  world: { sensed: [], contacts: [], resolution: 0.05 }, events: [],
  replay: null, replayT: null, planAt: null, planFrom: null, truth: false, drawn: null, features: { pause: false, resume: false },
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

// -- missions list ------------------------------------------------------------------------------
function age(iso) {
  const s = Math.max(0, (Date.now() - Date.parse(iso)) / 1000);
  if (s < 60) return `${s.toFixed(0)} s ago`;
  if (s < 3600) return `${(s / 60).toFixed(0)} min ago`;
  if (s < 86400) return `${(s / 3600).toFixed(0)} h ago`;
  return `${(s / 86400).toFixed(0)} d ago`;
}

const esc = (s) => String(s).replace(/[&<>"]/g, (c) => ({ "&": "&amp;", "<": "&lt;", ">": "&gt;", '"': "&quot;" })[c]);

async function loadMissions() {
  const status = $("filter").value;
  const page = await api(`/missions?limit=50${status ? `&status=${status}` : ""}`);
  $("total").textContent = `${page.items.length} of ${page.total}`;
  $("missions").innerHTML = page.items.map((m) => {
    const reached = m.goals.filter((g) => g.reached).length;
    const sel = state.mission && state.mission.id === m.id ? "selected" : "";
    return `<li data-id="${m.id}" data-status="${m.status}" class="${sel}" title="${esc(m.reason || m.status)}">` +
      `<span class="name">${esc(m.name)}</span><span class="st ${m.status}">${m.status}</span>` +
      `<span class="meta">goals ${reached}/${m.goals.length} · replans ${m.replans} · ${age(m.created_at)} · ${m.id.slice(0, 8)}</span></li>`;
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

function setStatus() {
  const m = state.mission;
  if (!m) return;
  const goals = `${(m.goals || []).filter((g) => g.reached).length}/${(m.goals || []).length} ` +
    (m.goals || []).map((g) => (g.reached ? "✓" : "○")).join("");
  const t = state.pose && state.pose.t !== undefined ? state.pose.t : m.model_time;
  $("status").innerHTML = `<b>${esc(m.name)}</b> <span class="st ${state.status}" id="mission-status">${state.status}</span> ` +
    `t = ${Number(t).toFixed(1)} s · goals ${goals} · replans ${m.replans}` +
    (state.reason ? ` · <span id="reason">${esc(state.reason)}</span>` : "");
  const ended = TERMINAL.includes(state.status);
  $("cancel").hidden = ended || state.status === "cancelling";
  $("pause").hidden = ended || !state.features.pause || state.status === "paused";
  $("resume").hidden = ended || !state.features.resume || state.status !== "paused";
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

function treeHtml(node) {
  const leaf = !node.children || !node.children.length;
  const current = leaf && node.status === "RUNNING" ? " current" : "";
  const fb = node.feedback ? ` <span class="fb">${esc(node.feedback)}</span>` : "";
  const kids = leaf ? "" : `<ul>${node.children.map(treeHtml).join("")}</ul>`;
  return `<li><span class="node ${node.status}${current}" data-status="${node.status}">${esc(node.name)}${fb}</span>${kids}</li>`;
}

function showTree(tree, t) {
  state.tree = tree && tree.name ? tree : null;
  $("tree").innerHTML = state.tree ? `<ul>${treeHtml(state.tree)}</ul>` : '<p class="muted">No tree snapshot yet.</p>';
  $("tree-time").textContent = state.tree && t !== undefined ? `t = ${Number(t).toFixed(1)} s` : "";
}

function eventText(e) {
  const skip = new Set(["t", "kind", "x", "y", "type", "old", "new", "detail", "at", "latency_ms", "version"]);
  const rest = Object.entries(e).filter(([k]) => !skip.has(k)).map(([k, v]) => `${k}=${typeof v === "object" ? JSON.stringify(v) : v}`);
  return `${Number(e.t).toFixed(1)} s ${e.kind} ${rest.join(" ")}`;
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

// -- replay -------------------------------------------------------------------------------------
function setReplayTime(t) {
  const r = state.replay;
  if (!r || !r.trajectory.length) return;
  state.replayT = t;
  const rows = r.trajectory;
  state.trail = rows.filter((row) => row[0] <= t);
  state.pose = poseOf(rowAt(rows, t));
  state.trail.push([t, state.pose.x, state.pose.y]);
  const version = r.plans.filter((p) => p.at === null || p.at <= t).pop();
  state.planAt = version && version.at !== null ? version.at : null;
  // The plan is drawn from where the robot was when it was made.
  const made = state.planAt === null ? null : rowAt(rows, state.planAt);
  state.planFrom = made ? poseOf(made) : null;
  showPlan(version ? version.actions : [], version ? version.version : 0);
  $("slider-t").textContent = `${t.toFixed(1)} s`;
  showEvents();
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
  if (token === selecting) state.world = { sensed: w.sensed, contacts: w.contacts, resolution: w.resolution || 0.05 };
}

function connect(id, token) {
  const ws = new WebSocket(`${location.protocol === "https:" ? "wss" : "ws"}://${location.host}/missions/${id}/ws`);
  state.socket = ws;
  ws.onmessage = (msg) => {
    if (token !== selecting) return;
    const f = JSON.parse(msg.data);
    if (f.type === "snapshot") {
      state.mission = f.mission; state.status = f.mission.status; state.reason = f.mission.reason;
      showPlan(f.plan.actions, f.plan.version);
    } else if (f.type === "state") {
      state.pose = { ...f.pose, t: f.t }; state.rays = f.sensors && f.sensors.rays ? f.sensors.rays : null;
      state.trail.push([f.t, f.pose.x, f.pose.y]); state.action = f.action || "";
      state.mission.model_time = f.t;
      showTree(f.tree, f.t); showPlan(state.plan);
    } else if (f.type === "plan") showPlan(f.actions, f.version);
    else if (f.type === "event") {
      if (f.kind === "status") {
        state.status = f.status; if (f.reason) state.reason = f.reason;
        const badge = document.querySelector(`#missions li[data-id="${id}"] .st`); // list polls slower
        if (badge) { badge.textContent = f.status; badge.className = `st ${f.status}`; }
      }
      else if (f.kind === "goal_reached" && state.mission.goals[f.goal]) state.mission.goals[f.goal].reached = true;
      else if (f.kind === "replan") state.mission.replans += 1;
      if (f.kind !== "status") {
        const e = { ...f, t: f.t !== undefined ? f.t : f.at };
        const p = state.pose;
        state.events.push(e.kind === "collision" && Array.isArray(e.at) ? { ...e, x: e.at[0], y: e.at[1] } : { ...e, x: p && p.x, y: p && p.y });
        showEvents();
      }
    } else if (f.type === "end") {
      state.status = f.status; state.reason = f.reason; state.live = false; state.rays = null;
      finish(id, token);
    }
    setStatus();
  };
}

async function finish(id, token) {
  const m = await api(`/missions/${id}`);
  if (token !== selecting) return;
  state.mission = m; state.status = m.status; state.reason = m.reason;
  await Promise.all([loadWorld(id, token), loadReplay(id, token), loadTreeOnce(id, token)]);
  loadMissions().catch(() => {});
  setStatus();
}

async function loadTreeOnce(id, token) {
  const tree = await api(`/missions/${id}/tree`);
  if (token !== selecting || !tree || !tree.name) return;
  showTree(tree);
  $("tree-time").textContent = "last snapshot";
}

// -- selection ----------------------------------------------------------------------------------
async function select(id) {
  const token = ++selecting;
  if (state.socket) state.socket.close();
  // Everything of the previous mission goes: sensed cells, events, trail, plan, tree, replay.
  Object.assign(state, {
    socket: null, pose: null, trail: [], plan: [], planVersion: 0, action: "", rays: null, reason: "",
    world: { sensed: [], contacts: [], resolution: 0.05 }, events: [], replay: null, replayT: null, live: false,
    planAt: null, planFrom: null,
  });
  showTree(null); showPlan([]); showEvents(); $("replay").hidden = true;
  const m = await api(`/missions/${id}`);
  if (token !== selecting) return;
  state.mission = m; state.status = m.status; state.reason = m.reason;
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

for (const verb of ["cancel", "pause", "resume"]) {
  $(verb).onclick = async () => {
    if (!state.mission) return;
    try {
      const m = await post(`/missions/${state.mission.id}/${verb}`);
      state.status = m.status; showError(""); setStatus();
    } catch { /* shown by api() */ }
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
attachControls($("arena"), cam, fitMission);
$("legend").innerHTML = legendHtml();

/** Live, the plan is drawn from the robot through the actions not yet done. */
function remainingFrom() {
  if (state.replayT !== null) return 0;
  const i = state.plan.indexOf(currentAction());
  return i < 0 ? 0 : i;
}

function frame() {
  state.drawn = drawScene($("arena"), cam, {
    mission: state.mission, world: state.world, truth: state.truth, trail: state.trail,
    pose: state.pose, plan: state.plan, current: currentAction(), rays: state.rays,
    planFrom: state.replayT === null ? null : state.planFrom, planStart: remainingFrom(),
    events: state.replayT === null ? state.events : state.events.filter((e) => e.t <= state.replayT),
  });
  requestAnimationFrame(frame);
}

async function start() {
  // Pause/resume buttons appear only when the API offers them.
  try {
    const spec = await fetch("/openapi.json").then((r) => r.json());
    state.features.pause = "/missions/{mission_id}/pause" in spec.paths;
    state.features.resume = "/missions/{mission_id}/resume" in spec.paths;
  } catch { /* no schema: no buttons */ }
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
