// The outline of the brief form: a rectangle, an L, a U or a T by its dimensions, or
// drawn on a snapping grid; the entrance at the middle of a side or clicked on the
// outline; obstacles as rows (x, y, width, depth, label) or dropped on the plan. All
// geometry here is the page's own (the service does none): axis-parallel polygons,
// counter-clockwise, their corners rounded to the centimetre.

const $ = (id) => document.getElementById(id);
const SVG_NS = "http://www.w3.org/2000/svg";
export const SIDES = ["north", "south", "east", "west"];
export const round = (v, digits = 2) => Number(Number(v).toFixed(digits));

/** Per shape: the labels of its two cut fields and their defaults (of width and depth). */
export const SHAPES = {
  rectangle: null,
  l: { cut: ["Cut width", "Cut depth"], note: "the north-east corner cut away",
       defaults: (w, d) => [round(w / 2), round(d / 2)] },
  u: { cut: ["Notch width", "Notch depth"], note: "a notch in the middle of the north side",
       defaults: (w, d) => [round(w / 3), round(d / 2)] },
  t: { cut: ["Corner cut width", "Corner cut depth"],
       note: "both south corners cut away: the stem is the width less twice the cut",
       defaults: (w, d) => [round(w / 4), round(d / 2)] },
};

/** The outline of `shape` with width `w`, depth `d` and cut `cx` x `cy`. */
export function outlineOf(shape, w, d, cx, cy) {
  if (shape === "l") {
    return [[0, 0], [w, 0], [w, round(d - cy)], [round(w - cx), round(d - cy)], [round(w - cx), d], [0, d]];
  }
  if (shape === "u") {
    const a = round((w - cx) / 2);
    return [[0, 0], [w, 0], [w, d], [round(w - a), d], [round(w - a), round(d - cy)], [a, round(d - cy)],
            [a, d], [0, d]];
  }
  if (shape === "t") {
    return [[cx, 0], [round(w - cx), 0], [round(w - cx), cy], [w, cy], [w, d], [0, d], [0, cy], [cx, cy]];
  }
  return [[0, 0], [w, 0], [w, d], [0, d]];
}

function boxOf(points) {
  const xs = points.map((p) => p[0]);
  const ys = points.map((p) => p[1]);
  return { x0: Math.min(...xs), y0: Math.min(...ys), x1: Math.max(...xs), y1: Math.max(...ys) };
}

/** The form's reading of an outline: {shape, w, d, cx, cy}, or shape "other" (drawn,
 * or written in the JSON) when no shape of the form gives exactly these corners. */
export function shapeOf(boundary) {
  if (!Array.isArray(boundary) || boundary.length < 4) return { shape: "rectangle" };
  const b = boxOf(boundary);
  const w = b.x1 - b.x0;
  const d = b.y1 - b.y0;
  const guesses = {
    rectangle: () => [0, 0],
    l: () => [w - boundary[3][0], d - boundary[3][1]],
    u: () => [w - 2 * boundary[5][0], d - boundary[5][1]],
    t: () => [boundary[0][0], boundary[2][1]],
  };
  if (boundary.length === 4 && b.x0 === 0 && b.y0 === 0 && boundary.every(([x, y]) =>
    (x === b.x0 || x === b.x1) && (y === b.y0 || y === b.y1))) {
    return { shape: "rectangle", w, d }; // in any order: the form writes it counter-clockwise
  }
  const corners = { rectangle: 4, l: 6, u: 8, t: 8 };
  const same = JSON.stringify(boundary);
  for (const [shape, guess] of Object.entries(guesses)) {
    if (boundary.length !== corners[shape] || b.x0 !== 0 || b.y0 !== 0) continue;
    const [cx, cy] = guess().map((v) => round(v));
    if (JSON.stringify(outlineOf(shape, w, d, cx, cy)) === same) {
      return shape === "rectangle" ? { shape, w, d } : { shape, w, d, cx, cy };
    }
  }
  return { shape: "other", w, d };
}

const edgesOf = (ring) => ring.map((p, k) => [p, ring[(k + 1) % ring.length]]);

const BEARINGS = { north: 0, east: 90, south: 180, west: 270 };
const PLAN_SIDES = ["north", "east", "south", "west"]; // by bearing, north up

/** The side of the plan (named as drawn, north up) nearest to facing the compass `side`
 * when true north is `north` degrees clockwise from the plan's up (the brief's `north`). */
export function planSide(side, north = 0) {
  const bearing = (((BEARINGS[side] + Number(north || 0)) % 360) + 360) % 360;
  return PLAN_SIDES[Math.round(bearing / 90) % 4];
}

/** The middle of the longest stretch of the outline on its bounding box's side facing
 * `side` (true north `north` degrees clockwise from the plan's up). */
export function entranceOf(side, boundary, north = 0) {
  if (!boundary?.length || !SIDES.includes(side)) return undefined;
  const b = boxOf(boundary);
  const line = { south: [1, b.y0], north: [1, b.y1], west: [0, b.x0], east: [0, b.x1] }[
    planSide(side, north)];
  const on = edgesOf(boundary).filter(([p, q]) => p[line[0]] === line[1] && q[line[0]] === line[1]);
  if (!on.length) return undefined;
  const length = ([p, q]) => Math.abs(p[0] - q[0]) + Math.abs(p[1] - q[1]);
  const [p, q] = on.reduce((a, e) => (length(e) > length(a) ? e : a));
  return [round((p[0] + q[0]) / 2), round((p[1] + q[1]) / 2)];
}

/** The side whose middle the entrance is at ("custom" elsewhere, kept as it is). */
export function sideOf(entrance, boundary, north = 0) {
  if (!entrance || !boundary) return "";
  const side = SIDES.find((s) => JSON.stringify(entranceOf(s, boundary, north))
    === JSON.stringify(entrance));
  return side ?? "custom";
}

/** The point of the outline nearest `point`, its free coordinate rounded to `step`. */
export function nearestOnOutline(boundary, [x, y], step = 0.1) {
  let best = null;
  for (const [p, q] of edgesOf(boundary)) {
    const [dx, dy] = [q[0] - p[0], q[1] - p[1]];
    const len2 = dx * dx + dy * dy;
    if (!len2) continue;
    const t = Math.max(0, Math.min(1, ((x - p[0]) * dx + (y - p[1]) * dy) / len2));
    let c = [p[0] + t * dx, p[1] + t * dy];
    if (dx === 0 || dy === 0) { // along an axis: rounded, and kept on the edge
      const k = dx === 0 ? 1 : 0;
      const [lo, hi] = [Math.min(p[k], q[k]), Math.max(p[k], q[k])];
      c[k] = Math.max(lo, Math.min(hi, Math.round(c[k] / step) * step));
    }
    c = c.map((v) => round(v));
    const dist = (c[0] - x) ** 2 + (c[1] - y) ** 2;
    if (!best || dist < best.dist) best = { point: c, dist };
  }
  return best?.point;
}

/** A drawn ring as an outline: counter-clockwise, from the origin, no repeated corner. */
export function normalRing(points) {
  const b = boxOf(points);
  let ring = points.map(([x, y]) => [round(x - b.x0), round(y - b.y0)]);
  ring = ring.filter((p, k) => JSON.stringify(p) !== JSON.stringify(ring[(k + 1) % ring.length]));
  // Corners on a straight run are not corners.
  ring = ring.filter((p, k) => {
    const a = ring[(k + ring.length - 1) % ring.length];
    const c = ring[(k + 1) % ring.length];
    return !((a[0] === p[0] && p[0] === c[0]) || (a[1] === p[1] && p[1] === c[1]));
  });
  const area = edgesOf(ring).reduce((s, [p, q]) => s + p[0] * q[1] - q[0] * p[1], 0);
  return area < 0 ? ring.reverse() : ring;
}

// Obstacles: rows of the form.

const OBSTACLE_FIELDS = [["x", "x m"], ["y", "y m"], ["width", "Width m"], ["depth", "Depth m"],
                         ["label", "Label"]];

/** Shows `obstacles` as rows; `changed()` after each edit of one. */
export function fillObstacles(obstacles, changed) {
  const box = $("obstacle-rows");
  box.replaceChildren();
  for (const o of obstacles ?? []) addObstacleRow(o, changed);
}

export function addObstacleRow(obstacle, changed) {
  const row = document.createElement("div");
  row.className = "obstacle-row";
  row.dataset.testid = "obstacle-row";
  for (const [name, label] of OBSTACLE_FIELDS) {
    const wrap = document.createElement("label");
    wrap.className = "cell";
    const span = document.createElement("span");
    span.textContent = label;
    const input = document.createElement("input");
    input.type = name === "label" ? "text" : "number";
    if (name !== "label") input.step = "any";
    input.value = obstacle[name] ?? "";
    input.dataset.field = name;
    input.dataset.testid = `obstacle-${name}`;
    wrap.append(span, input);
    row.append(wrap);
  }
  const remove = document.createElement("button");
  remove.type = "button";
  remove.textContent = "Remove";
  remove.setAttribute("aria-label", `remove obstacle ${obstacle.label ?? ""}`);
  remove.addEventListener("click", () => {
    row.remove();
    changed();
  });
  const errors = document.createElement("p");
  errors.className = "field-errors";
  row.append(remove, errors);
  $("obstacle-rows").append(row);
  return row;
}

/** The rows as the brief's obstacles (a blank label left out). */
export function obstaclesOfForm() {
  return [...document.querySelectorAll("#obstacle-rows .obstacle-row")].map((row) => {
    const value = (name) => row.querySelector(`[data-field='${name}']`).value;
    const o = {};
    for (const [name] of OBSTACLE_FIELDS.slice(0, 4)) o[name] = value(name) === "" ? null : Number(value(name));
    if (value("label").trim()) o.label = value("label").trim();
    return o;
  });
}

// Clicks on the plan: the entrance, an obstacle, an outline drawn corner by corner.

const state = { drawing: null, cursor: [0, 0], hooks: null };

function planPoint(svg, event) {
  const point = svg.createSVGPoint();
  point.x = event.clientX;
  point.y = event.clientY;
  const p = point.matrixTransform(svg.getScreenCTM().inverse());
  return [p.x, -p.y];
}

const snap = (v, step) => round(Math.round(v / step) * step);
const gridStep = () => Number($("grid-step").value) || 0.5;

/** The drawing board: a grid of `gridStep()` over the outline's box (at least 20 m
 * square) with the corners clicked so far. */
function drawBoard() {
  const svg = $("plan");
  svg.replaceChildren();
  const step = gridStep();
  const brief = state.hooks.brief();
  const b = brief?.boundary?.length ? boxOf(brief.boundary) : { x1: 0, y1: 0 };
  const size = Math.ceil(Math.max(20, 1.25 * b.x1, 1.25 * b.y1) / step) * step;
  svg.setAttribute("viewBox", `${-step} ${-size - step} ${size + 2 * step} ${size + 2 * step}`);
  const g = document.createElementNS(SVG_NS, "g");
  g.setAttribute("class", "board");
  svg.append(g);
  const line = (x1, y1, x2, y2, cls) => {
    const l = document.createElementNS(SVG_NS, "line");
    Object.entries({ x1, y1: -y1, x2, y2: -y2, class: cls }).forEach(([k, v]) => l.setAttribute(k, v));
    g.append(l);
  };
  for (let v = 0; v <= size + 1e-9; v += step) {
    const major = Math.abs(v - Math.round(v)) < 1e-9 ? "grid major" : "grid";
    line(v, 0, v, size, major);
    line(0, v, size, v, major);
  }
  const points = state.drawing;
  if (points.length) {
    const poly = document.createElementNS(SVG_NS, "polyline");
    poly.setAttribute("points", points.map(([x, y]) => `${x},${-y}`).join(" "));
    poly.setAttribute("class", "drawn");
    g.append(poly);
    for (const [x, y] of points) {
      const c = document.createElementNS(SVG_NS, "circle");
      Object.entries({ cx: x, cy: -y, r: step / 4, class: "corner" }).forEach(([k, v]) => c.setAttribute(k, v));
      g.append(c);
    }
  }
  const [cx, cy] = state.cursor; // the keyboard's cursor
  line(cx - step / 2, cy, cx + step / 2, cy, "cursor");
  line(cx, cy - step / 2, cx, cy + step / 2, "cursor");
  svg.dataset.source = "board";
  svg.dataset.cursor = `${cx},${cy}`;
  $("draw-note").textContent = (points.length
    ? `${points.length} corner(s): click the next, or the first to close the outline.`
    : "Click the first corner of the outline on the grid.")
    + " By keyboard: arrows move the cross, Enter puts a corner there, Escape stops.";
}

/** The board by keyboard: arrows move the cursor by a grid step, Enter or Space puts a
 * corner there, Escape stops drawing. */
function boardKey(event) {
  if (!state.drawing) return;
  const step = gridStep();
  const moves = { ArrowLeft: [-step, 0], ArrowRight: [step, 0], ArrowUp: [0, step], ArrowDown: [0, -step] };
  if (event.key in moves) {
    const [dx, dy] = moves[event.key];
    state.cursor = [round(Math.max(0, state.cursor[0] + dx)), round(Math.max(0, state.cursor[1] + dy))];
    drawBoard();
  } else if (event.key === "Enter" || event.key === " ") {
    addCorner(state.cursor);
  } else if (event.key === "Escape") {
    stopDrawing();
  } else {
    return;
  }
  event.preventDefault();
  event.stopPropagation();
}

/** A corner clicked while drawing: snapped to the grid, and square to the last one. */
function addCorner([x, y]) {
  const step = gridStep();
  let p = [snap(x, step), snap(y, step)];
  const points = state.drawing;
  const last = points[points.length - 1];
  if (last) {
    p = Math.abs(p[0] - last[0]) >= Math.abs(p[1] - last[1]) ? [p[0], last[1]] : [last[0], p[1]];
    if (p[0] === last[0] && p[1] === last[1]) return;
  }
  const first = points[0];
  if (first && points.length >= 3 && Math.hypot(p[0] - first[0], p[1] - first[1]) < step / 2 + 1e-9) {
    closeDrawing();
    return;
  }
  points.push(p);
  state.cursor = p;
  drawBoard();
}

/** Closes the drawn ring square (a corner added where the last and first do not line
 * up) and makes it the brief's outline. */
export function closeDrawing() {
  const points = state.drawing;
  if (!points || points.length < 3) return;
  const [first, last] = [points[0], points[points.length - 1]];
  if (first[0] !== last[0] && first[1] !== last[1]) points.push([last[0], first[1]]);
  const ring = normalRing(points);
  stopDrawing();
  if (ring.length >= 4) state.hooks.apply({ boundary: ring });
}

export function stopDrawing() {
  state.drawing = null;
  $("plan").removeAttribute("tabindex");
  $("draw-controls").hidden = true;
  if ($("place-mode").value === "outline") $("place-mode").value = "";
  state.hooks.redraw();
}

function startDrawing() {
  state.drawing = [];
  state.cursor = [0, 0];
  $("draw-controls").hidden = false;
  drawBoard();
  $("plan").setAttribute("tabindex", "0");
  $("plan").focus();
}

/** Wires the plan's clicks to the place mode; `hooks`: brief() the brief now,
 * apply(fields) merges fields into it, redraw() draws it again. */
export function setupPlacing(hooks) {
  state.hooks = hooks;
  $("place-mode").addEventListener("change", () => {
    if ($("place-mode").value === "outline") startDrawing();
    else if (state.drawing) stopDrawing();
  });
  $("close-outline").addEventListener("click", closeDrawing);
  $("cancel-drawing").addEventListener("click", stopDrawing);
  $("grid-step").addEventListener("change", () => state.drawing && drawBoard());
  $("plan").addEventListener("keydown", boardKey);
  // Before the plan's own listeners (fixing rooms): a click while placing is the brief's.
  $("output").addEventListener("click", (event) => {
    const svg = $("plan");
    const mode = $("place-mode").value;
    if (!mode || !svg.contains(event.target)) return;
    event.stopPropagation();
    const point = planPoint(svg, event);
    if (mode === "outline") {
      addCorner(point);
      return;
    }
    const brief = hooks.brief();
    if (!brief?.boundary?.length) return;
    if (mode === "entrance") {
      hooks.apply({ entrance: nearestOnOutline(brief.boundary, point) });
      $("place-mode").value = "";
    } else if (mode === "obstacle") {
      const step = gridStep();
      const [x, y] = [snap(point[0] - 0.5, step), snap(point[1] - 0.5, step)];
      hooks.apply({ obstacles: [...(brief.obstacles ?? []), { x, y, width: 1, depth: 1 }] });
    }
  }, true);
}
