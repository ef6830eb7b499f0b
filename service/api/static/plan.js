// Draws a problem's outline and a layout's rooms into an <svg>, from the polygons the
// API returns: no geometry is computed here beyond bounding boxes and label sizes.
// Drawing units are metres with y negated (SVG's y grows downwards, the plan's north).

const SVG_NS = "http://www.w3.org/2000/svg";

// The fills of the server's SVG plans (solver/export/svg.py), so both drawings agree.
const PALETTE = {
  living: "#f6e2b3", kitchen: "#f9c784", bedroom: "#b9d7f0", bathroom: "#a8e0df",
  dining: "#f7e3a1", foyer: "#d9cbe8", corridor: "#e4e4e4", study: "#c7e3b5",
  storage: "#d6ccc2", balcony: "#cfe8c8", office: "#c3cdea", stairs: "#cfcfcf",
  laundry: "#bfe3f2", shop: "#f3c6dc",
};
const UNCOVERED = "#ff9d9d";
const EMPTY = "#f4f4f2";
const LABEL_MAX_M = 0.5; // label height in metres at most, and at least a tenth of that
const GLYPH_WIDTH = 0.6; // typical glyph width / font size of a sans-serif face

/** A stable pastel for room types outside the palette (not the server's exact hue). */
export function roomFill(type) {
  const key = String(type ?? "").trim().toLowerCase();
  if (key in PALETTE) return PALETTE[key];
  let hash = 2166136261; // FNV-1a: stable across page loads
  for (const ch of key) hash = Math.imul(hash ^ ch.codePointAt(0), 16777619) >>> 0;
  return `hsl(${hash % 360} 60% 85%)`;
}

function el(name, attributes = {}, parent = null) {
  const node = document.createElementNS(SVG_NS, name);
  for (const [key, value] of Object.entries(attributes)) node.setAttribute(key, value);
  if (parent) parent.appendChild(node);
  return node;
}

const pointsOf = (polygon) => polygon.map(([x, y]) => `${x},${-y}`).join(" ");

function extent(points) {
  const xs = points.map((p) => p[0]);
  const ys = points.map((p) => p[1]);
  return { minX: Math.min(...xs), maxX: Math.max(...xs),
           minY: Math.min(...ys), maxY: Math.max(...ys) };
}

/** The largest rectangle of a room: its label goes there, where there is most room. */
function labelBox(room) {
  const rects = room.rectangles ?? [];
  if (rects.length) {
    return rects.reduce((a, b) => (b.width * b.depth > a.width * a.depth ? b : a));
  }
  const e = extent(room.polygon);
  return { x: e.minX, y: e.minY, width: e.maxX - e.minX, depth: e.maxY - e.minY };
}

function addLabel(group, room) {
  const box = labelBox(room);
  const lines = [room.id, `${Number(room.area).toFixed(1)} m²`];
  const longest = Math.max(...lines.map((l) => l.length));
  const size = Math.max(LABEL_MAX_M / 10, Math.min(LABEL_MAX_M,
    (0.9 * box.width) / (GLYPH_WIDTH * longest), (0.8 * box.depth) / (1.2 * lines.length)));
  const text = el("text", {
    x: box.x + box.width / 2, y: -(box.y + box.depth / 2), "font-size": size,
    "text-anchor": "middle", "dominant-baseline": "middle", class: "label",
  }, group);
  lines.forEach((line, k) => {
    const span = el("tspan", { x: box.x + box.width / 2,
                               dy: k === 0 ? `${-0.6 * (lines.length - 1)}em` : "1.2em" }, text);
    span.textContent = line; // text, never markup: ids are user input
    if (k > 0) span.setAttribute("class", "area");
  });
}

function addSegments(parent, segments, className) {
  for (const [[x1, y1], [x2, y2]] of segments) {
    el("line", { x1, y1: -y1, x2, y2: -y2, class: className }, parent);
  }
}

/**
 * Draws `problem` (outline, obstacles, entrance, the corridors' exits and routes) and,
 * when given, `layout` (corridors and aisles, rooms with labels; doors and windows once
 * final). `source` ("incumbent" or "result") is kept
 * on the svg as data-source; data-drawn counts the drawings made.
 */
export function drawPlan(svg, problem, layout = null, source = "problem") {
  svg.replaceChildren();
  const outline = problem?.boundary ?? [];
  if (outline.length < 3) return;
  const e = extent(outline);
  const pad = 0.04 * Math.max(e.maxX - e.minX, e.maxY - e.minY, 1);
  const arrow = source === "variant" || source === "previous" ? 0 : 2 * pad; // the north arrow's strip
  svg.setAttribute("viewBox", [e.minX - pad, -e.maxY - pad, e.maxX - e.minX + 2 * pad + arrow,
                               e.maxY - e.minY + 2 * pad].join(" "));

  const defs = el("defs", {}, svg);
  const hatch = el("pattern", { id: "hatch", width: 0.3, height: 0.3,
                                patternUnits: "userSpaceOnUse",
                                patternTransform: "rotate(45)" }, defs);
  el("line", { x1: 0, y1: 0, x2: 0, y2: 0.3, class: "hatch-line" }, hatch);

  // Under the rooms the free area shows red: whatever stays red is uncovered.
  el("polygon", { points: pointsOf(outline), fill: layout ? UNCOVERED : EMPTY,
                  class: "free" }, svg);
  for (const o of problem.obstacles ?? []) {
    const g = el("g", { class: "obstacle" }, svg);
    const box = { x: o.x, y: -(o.y + o.depth), width: o.width, height: o.depth };
    el("rect", { ...box, class: "solid" }, g); // not the red of uncovered floor below
    el("rect", { ...box, fill: "url(#hatch)" }, g);
    el("title", {}, g).textContent = o.label ?? "obstacle";
  }

  // Circulation (corridors, aisles) is covered floor: drawn under the rooms.
  const circulation = [...(layout?.corridors ?? []).map((c) => [c, "corridor"]),
                       ...(layout?.aisles ?? []).map((a) => [a, "aisle"])];
  for (const [shape, kind] of circulation) {
    const g = el("g", { class: kind, "data-id": shape.id }, svg);
    el("polygon", { points: pointsOf(shape.polygon), fill: PALETTE.corridor }, g);
    el("title", {}, g).textContent = `${shape.id}, ${shape.area} m²`;
  }

  const rooms = el("g", { class: "rooms" }, svg);
  for (const room of layout?.rooms ?? []) {
    const g = el("g", { class: "room", "data-room": room.id }, rooms);
    el("polygon", { points: pointsOf(room.polygon), fill: roomFill(room.type) }, g);
    el("title", {}, g).textContent = `${room.id} (${room.type}), ${room.area} m²`;
    addLabel(g, room);
  }
  el("polygon", { points: pointsOf(outline), class: "outline" }, svg);
  // Openings after the walls: they are drawn in the wall they pierce.
  addSegments(svg, (layout?.windows ?? []).map((w) => w.segment), "window");
  addSegments(svg, (layout?.doors ?? []).map((d) => d.segment), "door");
  // What the corridors must do: the exits, and each route as a dashed line.
  for (const route of problem.corridors?.routes ?? []) {
    const [[x1, y1], [x2, y2]] = route.between;
    const g = el("g", { class: "route" }, svg);
    el("line", { x1, y1: -y1, x2, y2: -y2 }, g);
    el("title", {}, g).textContent = route.max_walk == null ? "route"
      : `route, at most ${route.max_walk} m`;
  }
  for (const [x, y] of problem.corridors?.exits ?? []) {
    const g = el("g", { class: "exit" }, svg);
    el("rect", { x: x - pad / 4, y: -y - pad / 4, width: pad / 2, height: pad / 2 }, g);
    el("title", {}, g).textContent = "exit";
  }
  if (problem.entrance) {
    const [x, y] = problem.entrance;
    const g = el("g", { class: "entrance" }, svg);
    el("circle", { cx: x, cy: -y, r: pad / 3 }, g);
    el("title", {}, g).textContent = "entrance";
  }
  if (arrow) addNorth(svg, e.maxX + pad + arrow / 2, -e.maxY, arrow, Number(problem.north) || 0);
  svg.dataset.source = source;
  svg.dataset.drawn = String(Number(svg.dataset.drawn ?? 0) + 1);
}

/** A north arrow `size` wide, its tip at (x, y) in drawing units, in a strip right of
 * the outline, turned `north` degrees clockwise (the brief's `north`; 0: the plan's y
 * grows north, up). */
function addNorth(svg, x, y, size, north = 0) {
  const g = el("g", { class: "north", "aria-hidden": "true" }, svg);
  g.dataset.north = String(north);
  if (north) g.setAttribute("transform", `rotate(${north} ${x} ${y + size * 0.8})`);
  el("polygon", { points: `${x},${y} ${x - size * 0.3},${y + size} ${x},${y + size * 0.75} `
    + `${x + size * 0.3},${y + size}` }, g);
  const n = el("text", { x, y: y + size * 1.6, "font-size": size * 0.5, "text-anchor": "middle" }, g);
  n.textContent = "N";
}

/** Every room of a layout: its rooms, or those of every floor of a building. */
export function allRooms(layout) {
  return layout.floors ? layout.floors.flatMap((f) => f.rooms) : layout.rooms;
}

/** What the plan shows: the problem and layout as they are, or for a building of
 * several storeys its first floor (an incumbent's: the floor being solved), with that
 * floor's outline, obstacles and entrance. */
export function oneFloor(problem, layout) {
  if (!layout?.floors?.length || !problem?.floors) return [problem, layout];
  const shown = layout.floors[0];
  const index = Math.max(0, problem.floors.findIndex((f) => f.id === shown.id));
  const floor = problem.floors[index] ?? {};
  const view = {
    boundary: floor.boundary ?? problem.boundary,
    obstacles: floor.obstacles ?? problem.obstacles,
    entrance: floor.entrance ?? (index === 0 ? problem.entrance : null),
  };
  return [view, shown];
}
