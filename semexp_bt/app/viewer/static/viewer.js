// The semexp-bt view: the mission tree tick by tick, beside Rerun's world view, on one timeline.
//
// The page reads /api/session (mode, tree, where the world is) and /api/ticks (the tick records, polled
// while a mission runs). Each record holds the nodes ticked that tick (status, own ms, feedback), the
// nodes a parent stopped, and the blackboard writes. The full state at a tick is the replay of the
// records up to it; every SNAPSHOT_EVERY ticks a copy is kept, so scrubbing costs at most that many.
//
// The world view is the Rerun web viewer that rerun-notebook ships (/rerun/widget.js), driven through
// its widget interface: a "time_ctrl" message moves Rerun's time, and Rerun's "time_update" events move
// the tree. window.semexpView exposes the state for tests and for the console.

const SNAPSHOT_EVERY = 200;
const POLL_MS = 300;
const GLYPHS = { sequence: "{-}", selector: "{o}", parallel: "/_/", decorator: "-^-", behaviour: "-->" };
const TICK_PERIOD_S = 0.02;

const view = {
  session: null,
  records: [],          // tick records, in order
  tickIndex: new Map(), // tick number -> index in records
  snapshots: [],        // snapshots[k]: Map name -> [status, feedback] after records[k * SNAPSHOT_EVERY]
  index: -1,            // the record shown
  following: true,
  done: false,
  rerun: { ready: false, timeline: "tick", time: null, events: 0, error: null, pending: null, sought: null, resends: 0,
           unanswered: 0 },
  rows: new Map(),      // node name -> {li, ms, feedback, written}
};
window.semexpView = {
  get ticks() { return view.records.length; },
  get done() { return view.done; },
  get shownTick() { return view.index >= 0 ? view.records[view.index].tick : null; },
  get rerun() { return { ...view.rerun }; },
  statusOf(name) { const r = view.rows.get(name); return r ? r.li.dataset.status : null; },
  seek(tick) { seekTick(tick, { world: true }); },
  seekWorld(tick) { sendWorldTime(tick); },
};

const $ = (id) => document.getElementById(id);

// ------------------------------------------------------------------------------------------------ tree
function buildTree(structure) {
  const byName = new Map(structure.nodes.map((n) => [n.name, n]));
  const make = (node) => {
    const li = document.createElement("li");
    li.className = "node";
    li.dataset.name = node.name;
    li.dataset.kind = node.kind;
    li.dataset.status = "INVALID";
    li.dataset.visited = "false";
    const row = document.createElement("div");
    row.className = "row";
    const part = (cls, text = "") => {
      const span = document.createElement("span");
      span.className = cls;
      span.textContent = text;
      row.append(span);
      return span;
    };
    const toggle = part("toggle", node.children.length ? "▾" : "");
    part("glyph", GLYPHS[node.kind] || "-->");
    part("name", node.name);
    part("type", node.type);
    const ms = part("ms");
    const written = part("written");
    const feedback = part("feedback");
    li.append(row);
    if (node.children.length) {
      const ul = document.createElement("ul");
      for (const child of node.children) ul.append(make(byName.get(child)));
      li.append(ul);
      toggle.addEventListener("click", () => li.classList.toggle("collapsed"));
    }
    view.rows.set(node.name, { li, ms, feedback, written });
    return li;
  };
  $("tree").replaceChildren(make(byName.get(structure.root)));
}

function applyRecord(state, record) {
  for (const [name, node] of Object.entries(record.nodes)) state.set(name, [node.status, node.feedback]);
  for (const [name, status] of Object.entries(record.stopped || {})) {
    const old = state.get(name);
    state.set(name, [status, old ? old[1] : ""]);
  }
}

function stateAt(index) {
  const k = Math.floor(index / SNAPSHOT_EVERY);
  const state = new Map(view.snapshots[k]);
  for (let i = k * SNAPSHOT_EVERY + 1; i <= index; i++) applyRecord(state, view.records[i]);
  return state;
}

function addRecords(records) {
  for (const record of records) {
    const i = view.records.length;
    view.records.push(record);
    view.tickIndex.set(record.tick, i);
    if (i % SNAPSHOT_EVERY === 0) {
      const state = i === 0 ? new Map() : stateAt(i - 1);
      applyRecord(state, record);
      view.snapshots.push(state);
    }
  }
  const scrub = $("scrub");
  scrub.max = String(Math.max(view.records.length - 1, 0));
}

function render(index) {
  if (index < 0 || index >= view.records.length) return;
  view.index = index;
  const record = view.records[index];
  const state = stateAt(index);
  const writers = new Map();
  for (const w of record.writes) {
    if (!writers.has(w.client)) writers.set(w.client, []);
    writers.get(w.client).push(w.key.replace(/^\//, ""));
  }
  for (const [name, row] of view.rows) {
    const [status, feedback] = state.get(name) || ["INVALID", ""];
    const ticked = record.nodes[name];
    row.li.dataset.status = status;
    row.li.dataset.visited = ticked ? "true" : "false";
    row.ms.textContent = ticked ? `${ticked.ms.toFixed(3)} ms` : "";
    row.feedback.textContent = feedback || "";
    const keys = writers.get(name);
    row.written.textContent = keys ? `✎ ${keys.join(", ")}` : "";
  }
  const list = $("writes");
  list.replaceChildren(
    ...record.writes.map((w) => {
      const li = document.createElement("li");
      const value = JSON.stringify(w.value);
      li.textContent = `${w.key} ← ${w.client}: ${value && value.length > 240 ? value.slice(0, 240) + "…" : value}`;
      return li;
    }),
  );
  $("tick").textContent = String(record.tick);
  $("stamp").textContent = record.stamp_s.toFixed(2);
  $("scrub").value = String(index);
}

function seekTick(tick, { world }) {
  if (!view.records.length) return;
  let index = view.tickIndex.get(tick);
  if (index === undefined) index = nearestIndex((r) => r.tick <= tick);
  render(index);
  if (world) seekWorldFromTree(view.records[index].tick);
}

function nearestIndex(before) {
  let lo = 0, hi = view.records.length - 1;
  while (lo < hi) {
    const mid = (lo + hi + 1) >> 1;
    if (before(view.records[mid])) lo = mid; else hi = mid - 1;
  }
  return lo;
}

// ------------------------------------------------------------------------------------------------ world
const widget = { listeners: new Map() };

// After the tree moved Rerun, Rerun's reports of other times are its own cursor (a viewer still loading
// its recording, or one that has not applied the seek yet), not the user's: the tree keeps what the user
// chose and sends the seek again, until Rerun reports that time once, or at most this many times.
// A hold measured in wall time instead failed under load (docs/viewer.md, "Limits and risks").
const SEEK_RESENDS = 20;

function seekWorldFromTree(tick) {
  view.rerun.sought = tick;
  view.rerun.resends = 0;
  sendWorldTime(tick);
}

// Rerun's web viewer now and then takes a time command and reports nothing at all (session 29: one
// replay test in seven stayed at the old time for 30 s, no event after the command). A command after which
// no event of Rerun's comes within SEEK_SILENCE_MS is sent again, at most SEEK_RESENDS times; any event
// hands the matter to onWorldEvent.
const SEEK_SILENCE_MS = 2000;
let seekRetry = null;  // the pending resend's timer

function sendWorldTime(tick, unanswered = 0) {
  const handlers = widget.listeners.get("msg:custom") || [];
  const message = { type: "time_ctrl", timeline: "tick", sequence: String(tick), play: false };
  for (const handler of handlers) handler(message, []);
  clearTimeout(seekRetry);
  if (unanswered >= SEEK_RESENDS) return;
  const events = view.rerun.events;
  seekRetry = setTimeout(() => {
    if (view.rerun.events !== events) return;
    view.rerun.unanswered += 1;
    sendWorldTime(tick, unanswered + 1);
  }, SEEK_SILENCE_MS);
}

function onWorldEvent(message) {
  if (message === "ready") {
    view.rerun.ready = true;
    $("world-status").textContent = "world view: Rerun " + (view.session.world.kind === "grpc" ? "(live stream)" : "(saved recording)");
    // The recording is not open yet: the tick shown now is sent with Rerun's first event.
    if (!view.following && view.index >= 0) view.rerun.pending = view.records[view.index].tick;
    return;
  }
  let event;
  try { event = typeof message === "string" ? JSON.parse(message) : message; } catch { return; }
  view.rerun.events += 1;
  if (view.rerun.pending !== null && view.rerun.pending !== undefined) {
    const tick = view.rerun.pending;
    view.rerun.pending = null;
    seekWorldFromTree(tick);
    return;
  }
  if (event.type === "timeline_change") {
    view.rerun.timeline = event.timeline ?? event.timeline_name ?? view.rerun.timeline;
  }
  // Live, Rerun follows the stream a little behind the tree; only a pause (the user took hold of
  // Rerun's time) ends following.
  if (event.type === "pause" && view.following) {
    view.following = false;
    markFollow();
  }
  if (event.type === "time_update" || event.type === "timeline_change") {
    const time = Number(event.time);
    if (!Number.isFinite(time)) return;
    view.rerun.time = time;
    if (!view.records.length || view.following) return;
    if (view.rerun.sought !== null) {
      const arrived = view.rerun.timeline === "tick" && time === view.rerun.sought;
      if (arrived) {
        view.rerun.sought = null;
        return; // our seek came back: the tree is already there
      }
      if (view.rerun.resends < SEEK_RESENDS) {
        view.rerun.resends += 1;
        sendWorldTime(view.rerun.sought);
        return;
      }
      view.rerun.sought = null;
    }
    // Rerun moved (its own scrubber, or our seek coming back): the tree follows.
    const index = view.rerun.timeline === "sim_time"
      ? nearestIndex((r) => r.stamp_s * 1e9 <= time + 1e6)
      : nearestIndex((r) => r.tick <= time);
    if (index !== view.index) render(index);
  }
}

async function startWorld(world) {
  const status = $("world-status");
  if (!world) {
    status.textContent = "no world view in this session (recorded without Rerun)";
    return;
  }
  let module;
  try {
    module = await import("/rerun/widget.js");
  } catch (error) {
    view.rerun.error = String(error);
    status.textContent = "world view unavailable: the Rerun web viewer is not installed (pip install -e '.[viewer]')";
    return;
  }
  const el = $("rerun");
  const values = {
    _url: new URL(world.url, location.href).href,
    _width: "auto",
    _height: Math.max(el.clientHeight, 300),
    _panel_states: { blueprint: "collapsed", selection: "collapsed", time: "expanded" },
    _fallback_token: null,
    _theme: "dark",
  };
  const model = {
    get: (name) => values[name],
    set: (name, value) => { values[name] = value; },
    on: (name, handler) => {
      if (!widget.listeners.has(name)) widget.listeners.set(name, []);
      widget.listeners.get(name).push(handler);
    },
    off: () => {},
    send: (message) => onWorldEvent(message),
    save_changes: () => {},
  };
  status.textContent = "world view: loading Rerun…";
  try {
    module.default.render({ model, el });
  } catch (error) {
    view.rerun.error = String(error);
    status.textContent = "world view failed to start: " + error;
  }
  window.addEventListener("resize", () => {
    values._height = Math.max(el.clientHeight, 300);
    for (const handler of widget.listeners.get("change:_height") || []) handler(null, values._height);
  });
}

// ------------------------------------------------------------------------------------------------ ticks
async function poll() {
  while (true) {
    const after = view.records.length ? view.records[view.records.length - 1].tick : 0;
    let answer;
    try {
      answer = await (await fetch(`/api/ticks?after=${after}`)).json();
    } catch {
      $("world-status").textContent += " · the view's server has stopped";
      return;
    }
    if (answer.ticks.length) {
      addRecords(answer.ticks);
      if (view.following) render(view.records.length - 1);
      else if (view.index < 0) render(0);
    }
    if (answer.done) {
      const session = await (await fetch("/api/session")).json();
      if (session.outcome) $("outcome").textContent = "outcome: " + session.outcome;
      view.done = true;
      return;
    }
    if (!answer.ticks.length) await new Promise((resolve) => setTimeout(resolve, POLL_MS));
  }
}

function markFollow() {
  $("follow").classList.toggle("on", view.following);
}

function wireControls() {
  const scrub = $("scrub");
  scrub.addEventListener("input", () => {
    view.following = false;
    markFollow();
    render(Number(scrub.value));
    seekWorldFromTree(view.records[Number(scrub.value)].tick);
  });
  $("follow").addEventListener("click", () => {
    view.following = true;
    markFollow();
    render(view.records.length - 1);
    const handlers = widget.listeners.get("msg:custom") || [];
    for (const handler of handlers) handler({ type: "time_ctrl", timeline: "tick", play: true }, []);
  });
  let timer = null;
  $("play").addEventListener("click", () => {
    if (timer) { clearInterval(timer); timer = null; $("play").textContent = "▶"; return; }
    view.following = false;
    markFollow();
    $("play").textContent = "❚❚";
    timer = setInterval(() => {
      const speed = Number($("speed").value);
      const step = Math.max(1, Math.round((speed * 0.1) / TICK_PERIOD_S));
      const next = Math.min(view.index + step, view.records.length - 1);
      render(next);
      seekWorldFromTree(view.records[next].tick);
      if (next >= view.records.length - 1 && view.done) { clearInterval(timer); timer = null; $("play").textContent = "▶"; }
    }, 100);
  });
}

async function main() {
  view.session = await (await fetch("/api/session")).json();
  const session = view.session;
  document.title = `semexp-bt · ${session.title}`;
  $("title").textContent = session.title;
  $("mode").textContent = session.mode;
  $("mode").classList.toggle("live", session.mode === "live");
  view.following = session.mode === "live";
  markFollow();
  if (session.mode !== "live") $("follow").style.display = "none";
  buildTree(session.tree);
  wireControls();
  startWorld(session.world);
  await poll();
}

main();
