// Exploring a design: the variants of a result side by side, one picked onto the plan
// (the report and every download then describe it); rooms clicked there, or reached by
// Tab and Enter, are fixed; a room's target size is changed in place; "Re-solve" sends
// the edit through the service's edit API as it is (the kept rooms' polygons as `fixed`,
// the shown layout as `options.start`). With "keep" on, every room that does not touch
// a changed room is sent fixed too, so an edit stays local. The room chosen for a size
// has handles on its sides: dragging one (or Shift + an arrow key on the focused room)
// sets its width or depth. Each view on screen (job, report, plan, brief, downloads) is
// one state, and Undo / Redo step between them.

import { drawPlan } from "./plan.js";
import { drawVariantsTable, favourite } from "./variants.js";
import { meanAreaError } from "./verdict.js";

const $ = (id) => document.getElementById(id);
/** Walls closer than this (m) are one wall; a shared stretch shorter is a corner. */
const TOUCH_M = 0.01;
const MIN_CONTACT_M = 0.05;
/** A wall dragged or stepped by keyboard moves by multiples of this (m) ... */
const RESIZE_STEP_M = 0.1;
/** ... and leaves the room at least this wide and deep (m). */
const MIN_SIDE_M = 0.5;
const SVG_NS = "http://www.w3.org/2000/svg";

const state = {
  view: null,      // {job, info, problem, layouts, picked, locked, edited, previous, briefText}
  history: [],     // views before, for Undo
  future: [],      // views undone, for Redo
  editing: false,  // a re-solve is under way: its result is compared with the view before
  hooks: null,     // {resubmit(problem), show(view), briefText(problem)} from the page
};

const clone = (value) => JSON.parse(JSON.stringify(value));
const shown = (view = state.view) => view?.layouts[view.picked] ?? null;
const copyView = (v) => ({ ...v, problem: clone(v.problem), locked: new Set(v.locked),
                           edited: new Set(v.edited) });

/** Wires the panel to the page's hooks. */
export function setupExplore(hooks) {
  state.hooks = hooks;
  const plan = $("plan");
  plan.addEventListener("click", (event) => {
    const room = event.target.closest?.(".room");
    if (room && shown()) toggleLock(room.dataset.room);
  });
  plan.addEventListener("keydown", (event) => {
    const room = event.target.closest?.(".room");
    if (!room || !shown()) return;
    const id = room.dataset.room;
    if (event.shiftKey && ARROWS[event.key]) {
      event.preventDefault();
      resizeByKey(id, ARROWS[event.key]);
    } else if (event.key === "Enter" || event.key === " ") {
      event.preventDefault();
      toggleLock(id);
    } else {
      return;
    }
    $("plan").querySelector(`.room[data-room='${CSS.escape(id)}']`)?.focus();
  });
  plan.addEventListener("pointerdown", startDrag);
  $("edit-room").addEventListener("change", () => { showTarget(); drawHandles(); });
  $("apply-target").addEventListener("click", applyTarget);
  $("resolve").addEventListener("click", resolve);
  $("undo").addEventListener("click", undo);
  $("redo").addEventListener("click", redo);
}

/** The view on screen (for the page's downloads and reloads). */
export const currentView = () => state.view;

/** A job ended: `layout` of `problem` (the brief as solved, templates expanded), record
 * `info`. Returns false when the result is not one to explore (no rooms, or floors). */
export function exploreResult(job, info, layout, problem) {
  if (!layout?.rooms?.length || problem?.floors) {
    if (state.editing && retryWider()) return "retry";
    if (state.editing) { // an edit without a layout: the plan before stays, to undo to
      state.editing = false;
      const kept = state.kept?.size ?? 0;
      $("edit-note").textContent = "This edit found no layout (see the result)"
        + (kept ? ` with ${kept} room(s) kept in place: let more rooms move (untick "keep`
          + ' every room …" or free fixed rooms) and re-solve, or Undo.' : "; Undo goes back.");
      $("undo").disabled = state.history.length === 0;
    } else {
      $("explore").hidden = true;
    }
    return false;
  }
  const sent = clone(problem);
  if (sent.options) delete sent.options.start;
  const view = {
    job, info, problem: sent, layouts: layout.variants?.length ? layout.variants : [layout],
    picked: 0, locked: new Set((sent.rooms ?? []).filter((r) => r.fixed).map((r) => r.id)),
    edited: new Set(), previous: null, briefText: state.hooks.briefText(null),
  };
  if (state.editing && state.view) {
    const before = state.history[state.history.length - 1];
    view.previous = { problem: before.problem, layout: shown(before), kept: state.kept,
                      retried: state.ring === 2 ? state.retryNote : null };
    view.locked = new Set(before.locked);
  } else {
    state.history = [];
  }
  state.future = [];
  state.editing = false;
  state.view = view;
  $("explore").hidden = false;
  render("result");
  if (view.previous) $("edit-note").textContent = changeNote();
  return true;
}

function render(source = "explore") {
  drawThumbnails();
  drawVariantsTable(state.view, pick, drawThumbnails);
  drawShown(source);
  fillRoomList();
  drawHandles();
  drawComparison();
  $("undo").disabled = state.history.length === 0;
  $("redo").disabled = state.future.length === 0;
  state.hooks.show(state.view);
}

/** A variant's caption: how far its rooms are from their target areas, and coverage. */
function caption(layout, k) {
  const error = meanAreaError(state.view.problem, layout);
  const report = layout.report ?? {};
  const kept = favourite(state.view.job?.id ?? "", k);
  const parts = [`${kept.star ? "★ " : ""}#${k + 1}${kept.name ? ` ${kept.name}` : ""}`];
  if (error != null) parts.push(`areas off ${(100 * error).toFixed(0)} % on average`);
  if (report.coverage != null) parts.push(`${(100 * report.coverage).toFixed(1)} % covered`);
  if (report.valid === false) parts.push("invalid");
  return parts.join(" · ");
}

function drawThumbnails() {
  const strip = $("variants-strip");
  strip.replaceChildren();
  const { layouts, picked, problem } = state.view;
  strip.hidden = layouts.length < 2;
  layouts.forEach((layout, k) => {
    const button = document.createElement("button");
    button.type = "button";
    button.className = "variant-thumb";
    button.dataset.testid = "variant-thumb";
    button.dataset.index = String(k);
    button.setAttribute("aria-pressed", String(k === picked));
    const svg = document.createElementNS("http://www.w3.org/2000/svg", "svg");
    svg.setAttribute("class", "thumb");
    svg.setAttribute("aria-hidden", "true");
    drawPlan(svg, problem, layout, "variant");
    const text = document.createElement("span");
    text.textContent = caption(layout, k);
    button.append(svg, text);
    button.addEventListener("click", () => pick(k));
    strip.append(button);
  });
}

function pick(k) {
  state.view.picked = k;
  render();
}

function drawShown(source) {
  drawPlan($("plan"), state.view.problem, shown(), source);
  markLocks();
}

// Sizes on the plan: the chosen room's bounding box with a handle on each side.

/** Shift + arrow: the side that moves and which way (+1 out, -1 in). */
const ARROWS = { ArrowRight: ["east", 1], ArrowLeft: ["east", -1],
                 ArrowUp: ["north", 1], ArrowDown: ["north", -1] };

function svgEl(name, attributes, parent) {
  const node = document.createElementNS(SVG_NS, name);
  for (const [key, value] of Object.entries(attributes)) node.setAttribute(key, value);
  parent.append(node);
  return node;
}

/** The chosen room's bounding box on the plan, [x0, y0, x1, y1] in metres. */
function boxOfRoom(id) {
  const placed = shown()?.rooms.find((r) => r.id === id);
  if (!placed) return null;
  const xs = placed.polygon.map((p) => p[0]);
  const ys = placed.polygon.map((p) => p[1]);
  return [Math.min(...xs), Math.min(...ys), Math.max(...xs), Math.max(...ys)];
}

/** The room chosen in "Room" outlined on the plan, a handle on each side to drag. */
function drawHandles() {
  const svg = $("plan");
  svg.querySelector("g.handles")?.remove();
  const id = $("edit-room").value;
  const b = boxOfRoom(id);
  if (!b || !state.view) return;
  const outline = state.view.problem.boundary ?? [];
  const span = Math.max(...outline.map((p) => p[0])) - Math.min(...outline.map((p) => p[0]));
  const size = Math.max(0.15, 0.025 * span);
  const g = svgEl("g", { class: "handles", "data-room": id }, svg);
  svgEl("rect", { class: "size-box", x: b[0], y: -b[3], width: b[2] - b[0],
                  height: b[3] - b[1] }, g);
  const mid = [(b[0] + b[2]) / 2, (b[1] + b[3]) / 2];
  const at = { east: [b[2], mid[1]], west: [b[0], mid[1]], north: [mid[0], b[3]],
               south: [mid[0], b[1]] };
  for (const [side, [x, y]] of Object.entries(at)) {
    const handle = svgEl("rect", { class: `handle ${side}`, "data-side": side,
                                   x: x - size / 2, y: -y - size / 2, width: size, height: size }, g);
    svgEl("title", {}, handle).textContent = `drag to move ${id}'s ${side} wall`;
  }
}

/** Metres on the plan under a pointer event. */
function planPointOf(event) {
  const svg = $("plan");
  const p = svg.createSVGPoint();
  p.x = event.clientX;
  p.y = event.clientY;
  const m = p.matrixTransform(svg.getScreenCTM().inverse());
  return [m.x, -m.y];
}

const snap = (v) => Math.round(v / RESIZE_STEP_M) * RESIZE_STEP_M;

/** A handle dragged: the box follows the pointer, and on release the room's width or
 * depth is set to the box's (an undo step, as "Set size" is). */
function startDrag(event) {
  const handle = event.target.closest?.(".handle");
  if (!handle || !shown()) return;
  event.preventDefault();
  const id = $("edit-room").value;
  const side = handle.dataset.side;
  const b = boxOfRoom(id);
  const box = $("plan").querySelector("g.handles .size-box");
  const [x0, y0] = planPointOf(event);
  let moved = 0;
  handle.setPointerCapture(event.pointerId);
  const move = (e) => {
    const [x, y] = planPointOf(e);
    const along = side === "east" || side === "west" ? x - x0 : y - y0;
    const out = side === "east" || side === "north" ? along : -along;
    const full = side === "east" || side === "west" ? b[2] - b[0] : b[3] - b[1];
    moved = Math.max(snap(out), MIN_SIDE_M - full);
    const nb = [...b];
    if (side === "east") nb[2] += moved;
    if (side === "west") nb[0] -= moved;
    if (side === "north") nb[3] += moved;
    if (side === "south") nb[1] -= moved;
    box.setAttribute("x", nb[0]);
    box.setAttribute("y", -nb[3]);
    box.setAttribute("width", nb[2] - nb[0]);
    box.setAttribute("height", nb[3] - nb[1]);
  };
  const up = () => {
    handle.removeEventListener("pointermove", move);
    handle.removeEventListener("pointerup", up);
    handle.removeEventListener("pointercancel", up);
    if (Math.abs(moved) > 1e-9) resize(id, side, moved);
    else drawHandles();
  };
  handle.addEventListener("pointermove", move);
  handle.addEventListener("pointerup", up);
  handle.addEventListener("pointercancel", up);
}

/** Shift + an arrow key on a room: its east wall (or north) a step out or in. */
function resizeByKey(id, [side, sign]) {
  if ($("edit-room").value !== id) {
    $("edit-room").value = id;
    showTarget();
  }
  resize(id, side, sign * RESIZE_STEP_M);
}

/** The room's width (east, west) or depth (north, south) changed by `delta` metres from
 * what the size boxes say, then set as "Set size" sets it. */
function resize(id, side, delta) {
  const key = side === "east" || side === "west" ? "target-width" : "target-depth";
  const now = Number($(key).value);
  if (!(now > 0)) return;
  $(key).value = Math.max(MIN_SIDE_M, now + delta).toFixed(2);
  applyTarget();
}

/** Fixed rooms drawn as fixed; every room a keyboard stop that says what it is. */
function markLocks() {
  const { locked, previous } = state.view;
  const changed = new Set(previous ? changedRooms().map((c) => c.id) : []);
  for (const g of $("plan").querySelectorAll(".room")) {
    const id = g.dataset.room;
    const fixed = locked.has(id);
    g.classList.toggle("locked", fixed);
    g.classList.toggle("changed", changed.has(id));
    g.setAttribute("tabindex", "0");
    g.setAttribute("role", "button");
    g.setAttribute("aria-pressed", String(fixed));
    const room = shown().rooms.find((r) => r.id === id);
    g.setAttribute("aria-label", `${id}, ${room ? Number(room.area).toFixed(1) : "?"} m², `
      + (fixed ? "fixed: Enter frees it" : "Enter fixes it where it is"));
  }
  $("locked-count").textContent = String(locked.size);
}

function toggleLock(roomId) {
  const { locked } = state.view;
  if (locked.has(roomId)) locked.delete(roomId);
  else locked.add(roomId);
  markLocks();
  $("edit-room").value = roomId;
  showTarget();
}

function fillRoomList() {
  const select = $("edit-room");
  const chosen = select.value;
  select.replaceChildren();
  for (const room of state.view.problem.rooms ?? []) select.append(new Option(room.id, room.id));
  if (chosen && [...select.options].some((o) => o.value === chosen)) select.value = chosen;
  showTarget();
}

const roomOf = (id) => (state.view?.problem.rooms ?? []).find((r) => r.id === id);

/** The chosen room's width and depth on the plan now, else its target: its bounding
 * box's width, and for a room of several rectangles (an L) the depth that gives its
 * area at that width, so that a wider target asks for a strip more, not for the whole
 * bounding box. */
function showTarget() {
  const id = $("edit-room").value;
  const placed = shown()?.rooms.find((r) => r.id === id);
  const xs = placed?.polygon.map((p) => p[0]) ?? [];
  const ys = placed?.polygon.map((p) => p[1]) ?? [];
  const width = Math.max(...xs) - Math.min(...xs);
  const depth = (placed?.rectangles?.length ?? 1) > 1 ? placed.area / width
    : Math.max(...ys) - Math.min(...ys);
  const now = placed ? [width, depth] : null;
  const [w, d] = now ?? roomOf(id)?.target_size ?? ["", ""];
  $("target-width").value = w === "" ? "" : Number(w).toFixed(2);
  $("target-depth").value = d === "" ? "" : Number(d).toFixed(2);
}

/** The boxes' size into the brief as the room's target and, held, its minimum (its
 * maximum raised to it where below): an undo step of its own. */
function applyTarget() {
  const id = $("edit-room").value;
  const w = Number($("target-width").value);
  const d = Number($("target-depth").value);
  if (!roomOf(id) || !(w > 0) || !(d > 0)) {
    $("edit-note").textContent = "A target needs a positive width and depth.";
    return;
  }
  snapshot();
  const view = copyView(state.view);
  const room = view.problem.rooms.find((r) => r.id === id);
  room.target_size = [w, d];
  const held = $("hold-size").checked;
  if (held) {
    room.min_size = [w, d];
    if (room.max_size) room.max_size = room.max_size.map((m, k) => Math.max(m, room.min_size[k]));
  }
  view.edited.add(id);
  view.locked.delete(id); // a room whose size changes cannot stay where it is
  view.briefText = state.hooks.briefText(view.problem);
  state.view = view;
  render();
  $("target-width").value = w.toFixed(2); // as set, not the plan's size before
  $("target-depth").value = d.toFixed(2);
  $("edit-note").textContent = `${id}: ${held ? "at least" : "target"} ${w} × ${d} m; `
    + "Re-solve to see it.";
}

function snapshot() {
  state.history.push(copyView(state.view));
  state.future = [];
}

function touches(a, b) {
  for (const p of a.rectangles) {
    for (const q of b.rectangles) {
      const overlapX = Math.min(p.x + p.width, q.x + q.width) - Math.max(p.x, q.x);
      const overlapY = Math.min(p.y + p.depth, q.y + q.depth) - Math.max(p.y, q.y);
      if (overlapY > MIN_CONTACT_M && overlapX > -TOUCH_M) return true;
      if (overlapX > MIN_CONTACT_M && overlapY > -TOUCH_M) return true;
    }
  }
  return false;
}

/** The rooms kept in place: those fixed by hand, and with "keep" every room not touching
 * a room whose target changed. */
function keptRooms(ring = 1) {
  const { locked, edited } = state.view;
  const kept = new Set(locked);
  if ($("keep-others").checked && edited.size) {
    const rooms = shown().rooms;
    let free = rooms.filter((r) => edited.has(r.id));
    for (let k = 0; k < ring; k++) { // the changed rooms, their neighbours, theirs ...
      const ids = new Set(free.map((r) => r.id));
      free = rooms.filter((r) => ids.has(r.id) || free.some((f) => touches(f, r)));
    }
    const ids = new Set(free.map((r) => r.id));
    for (const room of rooms) if (!ids.has(room.id)) kept.add(room.id);
  }
  return kept;
}

function editedProblem(kept) {
  const problem = clone(state.view.problem);
  const layout = shown();
  const polygons = Object.fromEntries(layout.rooms.map((r) => [r.id, r.polygon]));
  for (const room of problem.rooms) {
    if (kept.has(room.id) && polygons[room.id]) room.fixed = polygons[room.id];
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
  const kept = keptRooms();
  const problem = editedProblem(kept);
  snapshot();
  state.kept = kept;
  state.ring = 1;
  state.editing = true;
  const free = state.view.problem.rooms.length - kept.size;
  $("edit-note").textContent = `Re-solving ${free} room(s) around ${kept.size} kept in place …`;
  state.hooks.resubmit(problem);
}

/** A local edit found no layout: once, the neighbours of the freed rooms are freed too,
 * and the note says which. Returns whether it was sent. */
function retryWider() {
  if (state.ring !== 1 || !$("keep-others").checked || !state.view.edited.size) return false;
  const kept = keptRooms(2);
  const freed = [...state.kept].filter((id) => !kept.has(id));
  if (!freed.length) return false;
  state.ring = 2;
  state.kept = kept;
  state.retryNote = `No layout with only the changed room's neighbours free, so their `
    + `neighbours were freed too: ${freed.join(", ")}.`;
  $("edit-note").textContent = `${state.retryNote} Re-solving …`;
  state.hooks.resubmit(editedProblem(kept));
  return true;
}

function undo() {
  const last = state.history.pop();
  if (!last) return;
  state.future.push(copyView(state.view));
  state.view = last;
  state.editing = false;
  render();
  $("edit-note").textContent = "Undone: plan, report, downloads and brief as before.";
}

function redo() {
  const next = state.future.pop();
  if (!next) return;
  state.history.push(copyView(state.view));
  state.view = next;
  render();
  $("edit-note").textContent = "Redone.";
}

/** Rooms whose polygon differs from the plan before the last re-solve. */
function changedRooms() {
  const { previous } = state.view;
  if (!previous?.layout) return [];
  const before = Object.fromEntries(previous.layout.rooms.map((r) => [r.id, r]));
  return shown().rooms.filter((r) => JSON.stringify(before[r.id]?.polygon) !== JSON.stringify(r.polygon))
    .map((r) => ({ id: r.id, before: before[r.id], after: r }));
}

function changeNote() {
  const changed = changedRooms();
  const total = shown().rooms.length;
  const kept = state.view.previous?.kept?.size ?? 0;
  let note = `Re-solved: ${changed.length} of ${total} rooms changed`;
  note += kept ? `, ${kept} kept in place.` : ".";
  if (!changed.length) note += " The plan before still meets the brief and scores as well, so it was kept.";
  if (state.view.previous?.retried) note = `${state.view.previous.retried} ${note}`;
  if (changed.length > total / 2) note += " Many rooms moved: fix the ones you want kept and re-solve, or Undo.";
  return `${note} The previous plan is beside the new one; Undo goes back.`;
}

function drawComparison() {
  const box = $("compare");
  const list = $("changes");
  list.replaceChildren();
  const { previous } = state.view;
  if (!previous?.layout) {
    box.hidden = true;
    return;
  }
  box.hidden = false;
  drawPlan($("previous-plan"), previous.problem, previous.layout, "previous");
  for (const { id, before, after } of changedRooms()) {
    const li = document.createElement("li");
    li.dataset.room = id;
    li.textContent = before
      ? `${id}: ${Number(before.area).toFixed(1)} → ${Number(after.area).toFixed(1)} m²`
      : `${id}: new, ${Number(after.area).toFixed(1)} m²`;
    list.append(li);
  }
  if (!list.children.length) {
    const li = document.createElement("li");
    li.textContent = "no room changed";
    list.append(li);
  }
}
