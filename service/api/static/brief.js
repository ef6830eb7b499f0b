// The brief without JSON: the outline (outline.js: a rectangle, L, U or T by its
// dimensions, or drawn on a grid), the entrance, obstacles, a room list (name, type,
// target area, smallest and largest side, neighbours, exterior wall) and the adjacency
// matrix (matrix.js, a view of the rooms' neighbours). The form and the JSON view are
// two views of one brief: a change in either rewrites the other, and fields the form
// does not show are kept.
// Blank sizes are left to the residential template, which the server expands.

import { drawBubbles } from "./bubbles.js";
import { drawMatrix } from "./matrix.js";
import { addObstacleRow, entranceOf, fillObstacles, obstaclesOfForm, outlineOf, round, SHAPES,
         setupPlacing, shapeOf, sideOf, SIDES } from "./outline.js";
import { hintFor } from "./words.js";

const $ = (id) => document.getElementById(id);

/** The residential template's room types (models/template_rules.py, KNOWN_TYPES). */
export const ROOM_TYPES = [
  "balcony", "bathroom", "bedroom", "closet", "corridor", "dining", "foyer", "garage",
  "hall", "kitchen", "laundry", "living", "office", "room", "stairs", "storage", "study", "wc",
];

/** Briefs to start from, made of the form's own fields. */
export const STARTERS = {
  "template:flat-6": {
    title: "10 × 8 m flat, six rooms (residential template)",
    brief: {
      name: "flat-10x8", boundary: [[0, 0], [10, 0], [10, 8], [0, 8]], entrance: [5, 0],
      template: "residential",
      rooms: [{ id: "hall", type: "hall" }, { id: "living", type: "living" },
              { id: "kitchen", type: "kitchen" }, { id: "bed1", type: "bedroom" },
              { id: "bed2", type: "bedroom" }, { id: "bath", type: "bathroom" }],
    },
  },
  "template:flat-5": {
    title: "9 × 7 m flat, five rooms by type only (residential template)",
    brief: {
      name: "flat-9x7", boundary: [[0, 0], [9, 0], [9, 7], [0, 7]], entrance: [4.5, 0],
      template: "residential",
      rooms: ["living", "kitchen", "bedroom", "bedroom", "bathroom"],
    },
  },
};

const state = { brief: null, onChange: null, rows: [] };

// The brief -> the form.

const sizeText = (size) => (!size ? "" : size[0] === size[1] ? String(size[0])
  : `${size[0]} x ${size[1]}`);

function exteriorOf(boundary) {
  if (!boundary?.length) return "";
  if (SIDES.every((s) => boundary.includes(s)) && boundary.length === 4) return "any";
  if (boundary.length === 1 && SIDES.includes(boundary[0])) return boundary[0];
  return "custom";
}

/** Shows `brief` in the form (not the JSON view). */
function fillForm(brief) {
  const outline = shapeOf(brief.boundary);
  $("outline-shape").value = outline.shape;
  $("outline-width").value = outline.w ?? "";
  $("outline-depth").value = outline.d ?? "";
  $("cut-width").value = outline.cx ?? "";
  $("cut-depth").value = outline.cy ?? "";
  $("north").value = String(brief.north ?? 0);
  $("entrance-side").value = sideOf(brief.entrance, brief.boundary, brief.north) || "";
  $("use-template").checked = Boolean(brief.template);
  showShape();
  fillObstacles(brief.obstacles, formChanged);
  const list = $("room-rows");
  list.replaceChildren();
  state.rows = [];
  (brief.rooms ?? []).forEach((room) => addRow(typeof room === "string" ? { type: room } : room,
                                               brief.adjacency ?? []));
  showMatrix();
}

function showShape() {
  const shape = $("outline-shape").value;
  const cut = SHAPES[shape];
  $("cut-box").hidden = !cut;
  if (cut) {
    $("cut-width-label").textContent = cut.cut[0];
    $("cut-depth-label").textContent = cut.cut[1];
  }
  const other = shape === "other";
  for (const id of ["outline-width", "outline-depth"]) $(id).disabled = other;
  $("outline-note").textContent = other ? "A drawn outline, or one with more corners than the "
    + "form's shapes: draw it again on the grid, edit it in the JSON view, or pick a shape to "
    + "replace it." : cut ? `${shape.toUpperCase()}: ${cut.note}.` : "";
}

// The adjacency matrix: a view of the rows' "Next to" fields.

const nextInput = (row) => row.querySelector("[data-field='next']");
const nameOf = (row) => row.querySelector("[data-field='name']").value.trim();
const listOf = (text) => text.split(",").map((s) => s.trim()).filter(Boolean);

function showMatrix() {
  const names = state.rows.map(({ row }) => nameOf(row));
  const pairs = state.rows.flatMap(({ row }) => listOf(nextInput(row).value)
    .map((b) => [nameOf(row), b]));
  drawMatrix(names, pairs, togglePair);
  const rooms = state.rows.map(({ row }, k) => ({
    name: names[k], type: row.querySelector("[data-field='type']").value,
    area: areaOfTarget(row.querySelector("[data-field='area']").value) }));
  drawBubbles(rooms, pairs, togglePair);
}

/** The area a row's target asks for (m²): the number, or width times depth; else null. */
function areaOfTarget(text) {
  const size = parseSize(String(text ?? ""));
  if (!size || size.some((v) => !(v > 0))) return null;
  return /[x×*]|\d\s+\d/.test(text) ? size[0] * size[1] : size[0];
}

/** A pair ticked (written in a's "Next to") or unticked (taken out of both rooms'). */
function togglePair(a, b, on) {
  const rowOf = (name) => state.rows.find(({ row }) => nameOf(row) === name)?.row;
  const edit = (row, other, add) => {
    if (!row) return;
    const list = listOf(nextInput(row).value).filter((n) => n !== other);
    if (add) list.push(other);
    nextInput(row).value = list.join(", ");
  };
  if (on) edit(rowOf(a), b, true);
  else {
    edit(rowOf(a), b, false);
    edit(rowOf(b), a, false);
  }
  formChanged();
}

function field(row, name, label, input) {
  const wrap = document.createElement("label");
  wrap.className = `cell ${name}`;
  const span = document.createElement("span");
  span.textContent = label;
  input.dataset.field = name;
  input.dataset.testid = `room-${name}`;
  wrap.append(span, input);
  row.append(wrap);
  return input;
}

function input(type, value, attrs = {}) {
  const el = document.createElement("input");
  el.type = type;
  el.value = value ?? "";
  for (const [k, v] of Object.entries(attrs)) el.setAttribute(k, v);
  return el;
}

function select(options, value) {
  const el = document.createElement("select");
  for (const [v, text] of options) el.append(new Option(text, v));
  if (value && ![...el.options].some((o) => o.value === value)) el.append(new Option(value, value));
  el.value = value ?? "";
  return el;
}

/** One room row; `room` the object it shows (kept for the fields the form lacks). */
function addRow(room = {}, adjacency = []) {
  const row = document.createElement("div");
  row.className = "room-row";
  row.dataset.testid = "room-row";
  const target = room.target_size;
  const area = target ? round(target[0] * target[1], 1) : "";
  const next = adjacency.filter((a) => a.a === room.id && a.b).map((a) => a.b);
  field(row, "name", "Name", input("text", room.id, { placeholder: "from type", size: 8 }));
  field(row, "type", "Type", select(ROOM_TYPES.map((t) => [t, t]), room.type ?? "room"));
  field(row, "area", "Target m² or w x d", input("text", area, { placeholder: "template", size: 6 }));
  field(row, "min", "Min side m", input("text", sizeText(room.min_size), { placeholder: "template", size: 5 }));
  field(row, "max", "Max side m", input("text", sizeText(room.max_size), { placeholder: "template", size: 5 }));
  field(row, "next", "Next to", input("text", next.join(", "), { placeholder: "names", size: 10 }));
  field(row, "exterior", "Outside wall", select([["", "template's choice"], ["any", "any side"],
    ...SIDES.map((s) => [s, s])], exteriorOf(room.boundary)));
  const remove = document.createElement("button");
  remove.type = "button";
  remove.className = "remove-room";
  remove.textContent = "Remove";
  remove.setAttribute("aria-label", `remove room ${room.id ?? room.type ?? ""}`);
  remove.addEventListener("click", () => {
    state.rows = state.rows.filter((r) => r.row !== row);
    row.remove();
    formChanged();
  });
  row.append(remove);
  const errors = document.createElement("p");
  errors.className = "field-errors";
  errors.setAttribute("aria-live", "polite");
  row.append(errors);
  $("room-rows").append(row);
  state.rows.push({ row, room, area });
  return row;
}

// The form -> the brief.

/** "3", "3 x 2.5", "3×2.5" as [width, depth]; null when blank; NaN parts when not numbers. */
function parseSize(text) {
  const t = text.trim();
  if (!t) return null;
  const parts = t.split(/\s*[x×*,]\s*|\s+/).map(Number);
  return parts.length === 1 ? [parts[0], parts[0]] : parts;
}

function roomOfRow({ row, room, area }) {
  const value = (name) => row.querySelector(`[data-field='${name}']`).value;
  const out = { ...room };
  delete out.id;
  const name = value("name").trim();
  const result = name ? { id: name } : {};
  Object.assign(result, out);
  result.type = value("type");
  const typed = value("area").trim();
  if (typed === "") delete result.target_size;
  else if (/[x×*]|\d\s+\d/.test(typed)) result.target_size = parseSize(typed); // width x depth
  else if (Number(typed) !== area || !room.target_size) {
    const side = round(Math.sqrt(Number(typed)));
    result.target_size = [side, side]; // a square of that area; the template fits the shape
  }
  for (const [key, size] of [["min_size", "min"], ["max_size", "max"]]) {
    const parsed = parseSize(value(size));
    if (parsed) result[key] = parsed;
    else delete result[key];
  }
  const exterior = value("exterior");
  if (exterior === "any") result.boundary = [...SIDES];
  else if (SIDES.includes(exterior)) result.boundary = [exterior];
  else if (exterior === "") delete result.boundary;
  return result;
}

function outlineOfForm() {
  const w = Number($("outline-width").value);
  const d = Number($("outline-depth").value);
  const shape = $("outline-shape").value;
  if (shape === "other" || !(w > 0) || !(d > 0)) return state.brief?.boundary;
  const [cx, cy] = SHAPES[shape]?.defaults(w, d) ?? [0, 0];
  return outlineOf(shape, w, d, Number($("cut-width").value) || cx, Number($("cut-depth").value) || cy);
}

function entranceOfForm(side, boundary, north) {
  if (side === "custom") return state.brief?.entrance;
  return entranceOf(side, boundary, north);
}

/** The north field as the brief's `north`: a number (0 left out, as the default), or
 * the text as typed for the service to refuse, naming the field. */
function northOfForm() {
  const text = $("north").value.trim();
  if (text === "") return undefined;
  const north = Number(text);
  return Number.isFinite(north) ? north : text;
}

/** The brief as the form has it, over the last brief (its other fields kept). */
function briefOfForm() {
  const brief = { ...(state.brief ?? {}) };
  brief.boundary = outlineOfForm();
  if (!brief.boundary) delete brief.boundary;
  const north = northOfForm();
  if (north) brief.north = north;
  else delete brief.north;
  const entrance = entranceOfForm($("entrance-side").value, brief.boundary, brief.north);
  if (entrance) brief.entrance = entrance;
  else delete brief.entrance;
  if ($("use-template").checked) brief.template = "residential";
  else delete brief.template;
  brief.rooms = state.rows.map(roomOfRow);
  brief.obstacles = obstaclesOfForm();
  if (!brief.obstacles.length) delete brief.obstacles;
  // Neighbours: the pairs the rows name; adjacencies the form cannot show are kept.
  const kept = (brief.adjacency ?? []).filter((a) => !a.b);
  const old = Object.fromEntries((brief.adjacency ?? []).filter((a) => a.b)
    .map((a) => [`${a.a}|${a.b}`, a]));
  const pairs = [];
  state.rows.forEach(({ row }, k) => {
    const a = brief.rooms[k].id;
    const text = row.querySelector("[data-field='next']").value;
    for (const b of text.split(",").map((s) => s.trim()).filter(Boolean)) {
      pairs.push({ ...(old[`${a}|${b}`] ?? {}), a: a ?? "", b });
    }
  });
  brief.adjacency = [...kept, ...pairs];
  if (!brief.adjacency.length) delete brief.adjacency;
  return brief;
}

// Both views.

function formChanged() {
  state.brief = briefOfForm();
  showMatrix();
  state.onChange?.(state.brief, "form");
}

/** Puts `brief` in the form; `fromJson` when it came from the JSON view. */
export function loadBrief(brief, fromJson = false) {
  state.brief = brief;
  const plain = brief && typeof brief === "object" && !Array.isArray(brief);
  $("brief-form").hidden = !plain;
  if (plain) {
    fillForm(brief);
    const noForm = brief.floors ? "A building of several floors is edited in the JSON view." : "";
    $("brief-note").textContent = noForm;
  }
  if (!fromJson) state.onChange?.(brief, "load");
}

export function currentBrief() {
  return state.brief;
}

/** Refused fields next to their inputs, with what to write instead; returns those the
 * form has no input for. */
export function showFieldErrors(errors) {
  for (const el of document.querySelectorAll(".field-errors")) el.replaceChildren();
  for (const el of document.querySelectorAll("#brief-form .invalid")) {
    el.classList.remove("invalid");
    el.removeAttribute("aria-invalid");
  }
  const names = state.rows.map(({ row }) => row.querySelector("[data-field='name']").value)
    .filter(Boolean);
  const unplaced = [];
  markOnPlan(errors);
  for (const error of errors) {
    const spot = placeOf(error);
    if (!spot) {
      unplaced.push(error);
      continue;
    }
    const hint = hintFor(error, names);
    const p = document.createElement("span");
    p.className = "field-error";
    p.dataset.field = error.field;
    p.textContent = `${spot.label}: ${error.message}${hint ? ` — ${hint}` : ""}`;
    spot.box.append(p);
    if (spot.input) {
      spot.input.classList.add("invalid");
      spot.input.setAttribute("aria-invalid", "true");
    }
  }
  return unplaced;
}

/** Geometric errors on the plan too: the obstacle or the entrance refused, or the
 * whole outline, drawn in the error colour. */
function markOnPlan(errors) {
  const plan = $("plan");
  for (const el of plan.querySelectorAll(".invalid")) el.classList.remove("invalid");
  for (const error of errors) {
    const [head, index] = String(error.field ?? "").split(".");
    const target = head === "obstacles" ? plan.querySelectorAll(".obstacle")[Number(index)]
      : head === "entrance" ? plan.querySelector(".entrance")
        : head === "boundary" ? plan.querySelector(".outline") : null;
    target?.classList.add("invalid");
  }
}

const FIELD_INPUT = { id: "name", type: "type", target_size: "area", min_size: "min",
                      max_size: "max", boundary: "exterior" };

function placeOf(error) {
  const path = String(error.field ?? "").split(".");
  if (path[0] === "rooms" && path.length >= 2 && state.rows[Number(path[1])]) {
    const { row } = state.rows[Number(path[1])];
    const name = FIELD_INPUT[path[2]];
    const input = name ? row.querySelector(`[data-field='${name}']`) : null;
    return { box: row.querySelector(".field-errors"), input,
             label: input ? input.closest("label").firstChild.textContent : path.slice(2).join(".") || "room" };
  }
  if (path[0] === "adjacency" && state.brief?.adjacency) {
    const adj = state.brief.adjacency[Number(path[1])];
    const k = (state.brief.rooms ?? []).findIndex((r) => r?.id === adj?.a);
    if (k >= 0 && state.rows[k]) {
      const { row } = state.rows[k];
      return { box: row.querySelector(".field-errors"),
               input: row.querySelector("[data-field='next']"), label: "Next to" };
    }
  }
  const obstacle = document.querySelectorAll("#obstacle-rows .obstacle-row")[Number(path[1])];
  if (path[0] === "obstacles" && obstacle) {
    const input = obstacle.querySelector(`[data-field='${path[2]}']`);
    return { box: obstacle.querySelector(".field-errors"), input,
             label: input ? input.closest("label").firstChild.textContent : "Obstacle" };
  }
  if (path[0] === "boundary" || path[0] === "entrance" || path[0] === "north") {
    const [input, label] = { boundary: ["outline-width", "Outline"],
                             entrance: ["entrance-side", "Entrance"], north: ["north", "North"] }[path[0]];
    return { box: $("outline-errors"), input: $(input), label };
  }
  return null;
}

/** Wires the form; `onChange(brief, origin)` after every change of the brief. */
export function setupBrief(onChange) {
  state.onChange = onChange;
  $("add-type").replaceChildren(...ROOM_TYPES.map((t) => new Option(t, t)));
  $("add-type").value = "bedroom";
  $("add-room").addEventListener("click", () => {
    // A programme line: that many rooms of that type; several are named type1, type2, ...
    // (past the names taken), one is left to be named.
    const type = $("add-type").value;
    const count = Math.min(20, Math.max(1, Math.round(Number($("add-count").value) || 1)));
    const taken = new Set(state.rows.map(({ row }) => nameOf(row)));
    const rows = [];
    for (let k = 1; rows.length < count; k++) {
      if (count === 1) {
        rows.push(addRow({ type }));
      } else if (!taken.has(`${type}${k}`)) {
        rows.push(addRow({ id: `${type}${k}`, type }));
      }
    }
    $("add-count").value = "1";
    formChanged();
    rows[0].querySelector("[data-field='name']").focus();
  });
  $("add-obstacle").addEventListener("click", () => {
    // A metre square in the middle of the outline's box, to move and size from there.
    const points = state.brief?.boundary ?? [[0, 0], [2, 2]];
    const mid = (k) => round(Math.floor((Math.min(...points.map((p) => p[k]))
      + Math.max(...points.map((p) => p[k]))) / 2 - 0.5));
    const row = addObstacleRow({ x: mid(0), y: mid(1), width: 1, depth: 1 }, formChanged);
    formChanged();
    row.querySelector("input").focus();
  });
  $("brief-form").addEventListener("input", (event) => {
    if (event.target.closest("#adjacency-matrix, #place-box, .add-rooms")) return; // their own handlers
    if (event.target.id === "outline-shape") showShape();
    formChanged();
  });
  setupPlacing({
    brief: () => state.brief,
    apply: (fields) => {
      loadBrief({ ...(state.brief ?? {}), ...fields });
    },
    redraw: () => state.onChange?.(state.brief, "redraw"),
  });
}
