// Exploring a design: the variants of a result as thumbnails side by side,
// one picked onto the plan; rooms clicked there are fixed (drawn locked) and a room's
// target size is changed in place; "Re-solve" sends the edit (the locked rooms'
// polygons as `fixed`, the shown layout as `options.start`); the previous plan stays
// beside the new one, with what changed; "Undo" goes back one edit. The page's own
// submit path runs the job (`resubmit`), so an edit is followed like any job.

import { drawPlan } from "./plan.js";

const $ = (id) => document.getElementById(id);

const state = {
  problem: null,   // the problem of the plan on screen, as sent (without start)
  layouts: [],     // the variants of the last result (one when none were asked)
  picked: 0,       // the variant on the plan
  locked: new Set(),
  previous: null,  // {problem, layout}: the plan before the last re-solve
  history: [],     // [{problem, layouts, picked, locked, previous}] for undo
  editing: false,  // a re-solve is under way: its result is compared with `previous`
  resubmit: null,  // (problem) => void, from the page
};

const clone = (value) => JSON.parse(JSON.stringify(value));
const shown = () => state.layouts[state.picked] ?? null;

/** Wires the panel; `resubmit(problem)` sends a problem as the Solve button does. */
export function setupExplore(resubmit) {
  state.resubmit = resubmit;
  $("plan").addEventListener("click", (event) => {
    const room = event.target.closest?.(".room");
    if (!room || !shown()) return;
    toggleLock(room.dataset.room);
  });
  $("edit-room").addEventListener("change", showTarget);
  $("apply-target").addEventListener("click", applyTarget);
  $("resolve").addEventListener("click", resolve);
  $("undo").addEventListener("click", undo);
}

/** A job ended with `layout` (of `problem`): offer its variants for exploring. A
 * building of several floors is not explored (fixed rooms are for one floor). */
export function exploreResult(problem, layout) {
  const panel = $("explore");
  if (!layout?.rooms?.length || problem?.floors) {
    if (state.editing) { // an edit without a layout: the plan before stays, to undo to
      state.editing = false;
      $("edit-note").textContent = "This edit has no layout (see above); Undo goes back.";
      render();
    } else {
      panel.hidden = true;
    }
    return;
  }
  const sent = clone(problem);
  if (sent.options) delete sent.options.start;
  if (state.editing && state.problem) {
    state.previous = { problem: state.problem, layout: shown() };
    $("edit-note").textContent = "Re-solved: the previous plan is beside the new one; "
      + "Undo goes back.";
  } else {
    state.previous = null;
    state.history = [];
    state.locked = new Set((sent.rooms ?? []).filter((r) => r.fixed).map((r) => r.id));
  }
  state.editing = false;
  state.problem = sent;
  state.layouts = layout.variants?.length ? layout.variants : [layout];
  state.picked = 0;
  panel.hidden = false;
  render("result");
}

/** Draws the panel and the plan; `source` goes on the plan's data-source ("result"
 * as a job ended, "explore" once a variant is picked or an edit undone). */
function render(source = "explore") {
  drawThumbnails();
  drawShown(source);
  fillRoomList();
  drawComparison();
  $("undo").disabled = state.history.length === 0;
}

function drawThumbnails() {
  const strip = $("variants-strip");
  strip.replaceChildren();
  strip.hidden = state.layouts.length < 2;
  state.layouts.forEach((layout, k) => {
    const button = document.createElement("button");
    button.type = "button";
    button.className = "variant-thumb";
    button.dataset.index = String(k);
    button.setAttribute("aria-pressed", String(k === state.picked));
    const svg = document.createElementNS("http://www.w3.org/2000/svg", "svg");
    svg.setAttribute("class", "thumb");
    drawPlan(svg, state.problem, layout, "variant");
    const caption = document.createElement("span");
    const objective = layout.report?.objective;
    caption.textContent = `#${k + 1}` + (objective == null ? "" : ` · ${objective.toFixed(1)}`);
    button.append(svg, caption);
    button.addEventListener("click", () => pick(k));
    strip.append(button);
  });
}

function pick(k) {
  state.picked = k;
  render();
}

/** The picked layout on the main plan, its locked rooms marked. */
function drawShown(source) {
  drawPlan($("plan"), state.problem, shown(), source);
  markLocks($("plan"));
}

function markLocks(svg) {
  for (const g of svg.querySelectorAll(".room")) {
    const locked = state.locked.has(g.dataset.room);
    g.classList.toggle("locked", locked);
    g.setAttribute("aria-label", `${g.dataset.room}${locked ? " (fixed)" : ""}`);
  }
  $("locked-count").textContent = String(state.locked.size);
}

function toggleLock(roomId) {
  if (state.locked.has(roomId)) state.locked.delete(roomId);
  else state.locked.add(roomId);
  markLocks($("plan"));
  $("edit-room").value = roomId;
  showTarget();
}

function fillRoomList() {
  const select = $("edit-room");
  const chosen = select.value;
  select.replaceChildren();
  for (const room of state.problem?.rooms ?? []) select.append(new Option(room.id, room.id));
  if (chosen && [...select.options].some((o) => o.value === chosen)) select.value = chosen;
  showTarget();
}

function roomOf(id) {
  return (state.problem?.rooms ?? []).find((r) => r.id === id);
}

/** The chosen room's target size in the two boxes (empty without one). */
function showTarget() {
  const room = roomOf($("edit-room").value);
  const [w, d] = room?.target_size ?? ["", ""];
  $("target-width").value = w === "" ? "" : Number(w).toFixed(2);
  $("target-depth").value = d === "" ? "" : Number(d).toFixed(2);
}

/** The boxes' target size into the problem (kept for the re-solve; undo restores). */
function applyTarget() {
  const room = roomOf($("edit-room").value);
  const w = Number($("target-width").value);
  const d = Number($("target-depth").value);
  if (!room || !(w > 0) || !(d > 0)) {
    $("edit-note").textContent = "A target needs a positive width and depth.";
    return;
  }
  snapshot();
  room.target_size = [w, d];
  $("edit-note").textContent = `${room.id}: target ${w} × ${d} m, re-solve to see it.`;
  $("undo").disabled = false;
}

function snapshot() {
  state.history.push({
    problem: clone(state.problem), layouts: state.layouts, picked: state.picked,
    locked: new Set(state.locked), previous: state.previous,
  });
}

/** The edit as a problem: the locked rooms fixed at their polygons on the plan, the
 * others free, the plan's layout as the start; one variant. */
function editedProblem() {
  const problem = clone(state.problem);
  const layout = shown();
  const polygons = Object.fromEntries(layout.rooms.map((r) => [r.id, r.polygon]));
  for (const room of problem.rooms) {
    if (state.locked.has(room.id) && polygons[room.id]) room.fixed = polygons[room.id];
    else delete room.fixed;
  }
  const options = { ...(problem.options ?? {}) };
  delete options.variants;
  options.start = layout.rooms.map((r) => ({ id: r.id, rectangles: r.rectangles }));
  problem.options = options;
  return problem;
}

function resolve() {
  if (!shown()) return;
  const problem = editedProblem();
  snapshot();
  state.editing = true;
  $("edit-note").textContent = `Re-solving with ${state.locked.size} room(s) fixed …`;
  state.resubmit(problem);
}

function undo() {
  const last = state.history.pop();
  if (!last) return;
  Object.assign(state, last);
  state.editing = false;
  $("edit-note").textContent = "Undone.";
  render();
}

/** The plan before the last re-solve, beside the new one, and the rooms that changed. */
function drawComparison() {
  const box = $("compare");
  const list = $("changes");
  list.replaceChildren();
  if (!state.previous?.layout) {
    box.hidden = true;
    return;
  }
  box.hidden = false;
  drawPlan($("previous-plan"), state.previous.problem, state.previous.layout, "previous");
  const before = Object.fromEntries(state.previous.layout.rooms.map((r) => [r.id, r]));
  for (const room of shown().rooms) {
    const old = before[room.id];
    if (old && JSON.stringify(old.polygon) === JSON.stringify(room.polygon)) continue;
    const li = document.createElement("li");
    li.dataset.room = room.id;
    li.textContent = old
      ? `${room.id}: ${Number(old.area).toFixed(1)} → ${Number(room.area).toFixed(1)} m²`
      : `${room.id}: new, ${Number(room.area).toFixed(1)} m²`;
    list.append(li);
  }
  if (!list.children.length) {
    const li = document.createElement("li");
    li.textContent = "no room changed";
    list.append(li);
  }
}
