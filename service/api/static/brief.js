// The brief without JSON: the outline by width and depth (a rectangle or an L), the
// entrance's side, and a room list (name, type, target area, smallest and largest side,
// neighbours, exterior wall). The form and the JSON view are two views of one brief:
// a change in either rewrites the other, and fields the form does not show are kept.
// Blank sizes are left to the residential template, which the server expands.

import { hintFor } from "./words.js";

const $ = (id) => document.getElementById(id);

/** The residential template's room types (models/template_rules.py, KNOWN_TYPES). */
export const ROOM_TYPES = [
  "balcony", "bathroom", "bedroom", "closet", "corridor", "dining", "foyer", "garage",
  "hall", "kitchen", "laundry", "living", "office", "room", "stairs", "storage", "study", "wc",
];
const SIDES = ["north", "south", "east", "west"];

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
const round = (v, digits = 2) => Number(Number(v).toFixed(digits));

// The brief -> the form.

function boxOf(points) {
  const xs = points.map((p) => p[0]);
  const ys = points.map((p) => p[1]);
  return { x0: Math.min(...xs), y0: Math.min(...ys), x1: Math.max(...xs), y1: Math.max(...ys) };
}

/** The outline as the form's shape: a rectangle, our L (a corner cut at the north-east)
 * or "other" (kept as written, edited in JSON). */
function shapeOf(boundary) {
  if (!Array.isArray(boundary) || boundary.length < 4) return { shape: "rectangle" };
  const b = boxOf(boundary);
  const w = b.x1 - b.x0;
  const d = b.y1 - b.y0;
  if (boundary.length === 4 && boundary.every(([x, y]) => (x === b.x0 || x === b.x1)
      && (y === b.y0 || y === b.y1)) && b.x0 === 0 && b.y0 === 0) {
    return { shape: "rectangle", w, d };
  }
  const l = lShape(w, d, 0, 0);
  if (boundary.length === 6 && b.x0 === 0 && b.y0 === 0 && boundary[3]) {
    const [cx, cy] = [w - boundary[3][0], d - boundary[3][1]];
    if (JSON.stringify(lShape(w, d, cx, cy)) === JSON.stringify(boundary)) {
      return { shape: "l", w, d, cx, cy };
    }
  }
  return { shape: "other", w, d, l };
}

function lShape(w, d, cx, cy) {
  return [[0, 0], [w, 0], [w, round(d - cy)], [round(w - cx), round(d - cy)], [round(w - cx), d], [0, d]];
}

/** The side whose middle the entrance is at ("custom" elsewhere, kept as written). */
function sideOf(entrance, boundary) {
  if (!entrance || !boundary) return "";
  const side = SIDES.find((s) => JSON.stringify(entranceOf(s, boundary)) === JSON.stringify(entrance));
  return side ?? "custom";
}

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
  $("entrance-side").value = sideOf(brief.entrance, brief.boundary) || "";
  $("use-template").checked = Boolean(brief.template);
  showShape();
  const list = $("room-rows");
  list.replaceChildren();
  state.rows = [];
  (brief.rooms ?? []).forEach((room) => addRow(typeof room === "string" ? { type: room } : room,
                                               brief.adjacency ?? []));
}

function showShape() {
  const shape = $("outline-shape").value;
  $("cut-box").hidden = shape !== "l";
  const other = shape === "other";
  for (const id of ["outline-width", "outline-depth"]) $(id).disabled = other;
  $("outline-note").textContent = other ? "This outline has more corners than the form "
    + "draws: edit it in the JSON view, or pick a rectangle or an L to replace it." : "";
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
  field(row, "area", "Target m²", input("number", area, { min: 0, step: "any", placeholder: "template" }));
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
  const typed = value("area");
  if (typed === "") delete result.target_size;
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
  if (shape === "l") {
    const cx = Number($("cut-width").value) || round(w / 2);
    const cy = Number($("cut-depth").value) || round(d / 2);
    return lShape(w, d, cx, cy);
  }
  return [[0, 0], [w, 0], [w, d], [0, d]];
}

function entranceOf(side, boundary) {
  if (!boundary || !side) return undefined;
  if (side === "custom") return state.brief?.entrance;
  const b = boxOf(boundary);
  // The middle of that side's edge of the outline (the L's north side is its west arm).
  const northEdge = boundary.filter(([, y]) => y === b.y1).map(([x]) => x);
  const eastEdge = boundary.filter(([x]) => x === b.x1).map(([, y]) => y);
  const mid = (vals) => round((Math.min(...vals) + Math.max(...vals)) / 2);
  return { south: [mid([b.x0, b.x1]), b.y0], north: [mid(northEdge), b.y1],
           west: [b.x0, mid([b.y0, b.y1])], east: [b.x1, mid(eastEdge)] }[side];
}

/** The brief as the form has it, over the last brief (its other fields kept). */
function briefOfForm() {
  const brief = { ...(state.brief ?? {}) };
  brief.boundary = outlineOfForm();
  if (!brief.boundary) delete brief.boundary;
  const entrance = entranceOf($("entrance-side").value, brief.boundary);
  if (entrance) brief.entrance = entrance;
  else delete brief.entrance;
  if ($("use-template").checked) brief.template = "residential";
  else delete brief.template;
  brief.rooms = state.rows.map(roomOfRow);
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
  if (path[0] === "boundary" || path[0] === "entrance") {
    return { box: $("outline-errors"), input: $(path[0] === "boundary" ? "outline-width" : "entrance-side"),
             label: path[0] === "boundary" ? "Outline" : "Entrance" };
  }
  return null;
}

/** Wires the form; `onChange(brief, origin)` after every change of the brief. */
export function setupBrief(onChange) {
  state.onChange = onChange;
  $("add-room").addEventListener("click", () => {
    const row = addRow({ type: "bedroom" });
    formChanged();
    row.querySelector("[data-field='name']").focus();
  });
  $("brief-form").addEventListener("input", (event) => {
    if (event.target.id === "outline-shape") showShape();
    formChanged();
  });
}
