// Adjacencies as a bubble diagram: one bubble per named room, its size by its target area,
// a line between two rooms the brief asks to share a wall. Another view of the rooms'
// "Next to", as the matrix is: pick a bubble, then another to pair the two (or unpair
// them); by keyboard, Tab to a bubble and press Enter (or Space) the same way.

import { roomFill } from "./plan.js";

const $ = (id) => document.getElementById(id);
const SVG_NS = "http://www.w3.org/2000/svg";
const key = (a, b) => (a < b ? `${a}|${b}` : `${b}|${a}`);
/** The diagram's drawing units and its bubbles' radii (m² of target area -> units). */
const WIDTH = 320;
const HEIGHT = 240;
const MIN_R = 13;
const MAX_R = 30;
const R_PER_M = 3.2;
/** The area a room without a target is drawn at (m²). */
const UNKNOWN_AREA = 10;

let picked = null; // the bubble picked first, waiting for its partner

function el(name, attributes, parent) {
  const node = document.createElementNS(SVG_NS, name);
  for (const [k, v] of Object.entries(attributes)) node.setAttribute(k, v);
  parent.append(node);
  return node;
}

/**
 * Draws `rooms` ([{name, type, area}], area in m² or null) as bubbles on a ring, with a
 * line for each pair of `pairs` ([a, b] lists); `onToggle(a, b, on)` when a pair is
 * picked. The focus stays on the bubble last pressed.
 */
export function drawBubbles(rooms, pairs, onToggle) {
  const svg = $("bubbles");
  const focused = document.activeElement?.closest?.("#bubbles")
    ? document.activeElement.dataset.room : null;
  svg.replaceChildren();
  const seen = new Set();
  const named = rooms.filter((r) => r.name && !seen.has(r.name) && seen.add(r.name));
  if (picked && !seen.has(picked)) picked = null;
  svg.setAttribute("viewBox", `0 0 ${WIDTH} ${HEIGHT}`);
  const radius = (r) => Math.min(MAX_R, Math.max(MIN_R, R_PER_M * Math.sqrt(r.area || UNKNOWN_AREA)));
  const ring = [WIDTH / 2 - MAX_R - 4, HEIGHT / 2 - MAX_R - 4];
  const at = new Map(named.map((r, k) => {
    const t = -Math.PI / 2 + (2 * Math.PI * k) / Math.max(named.length, 1);
    return [r.name, [WIDTH / 2 + ring[0] * Math.cos(t), HEIGHT / 2 + ring[1] * Math.sin(t)]];
  }));
  const bonds = el("g", { class: "bonds" }, svg);
  const drawn = new Set();
  for (const [a, b] of pairs) {
    if (!at.has(a) || !at.has(b) || a === b || drawn.has(key(a, b))) continue;
    drawn.add(key(a, b));
    const [[x1, y1], [x2, y2]] = [at.get(a), at.get(b)];
    el("line", { x1, y1, x2, y2, class: "bond", "data-pair": key(a, b) }, bonds);
  }
  for (const room of named) {
    const [x, y] = at.get(room.name);
    const g = el("g", { class: `bubble${room.name === picked ? " picked" : ""}`,
                        tabindex: "0", role: "button", "data-room": room.name,
                        "data-testid": "bubble",
                        "aria-pressed": String(room.name === picked),
                        "aria-label": `${room.name}${room.name === picked ? ", picked" : ""}: `
                          + (picked && picked !== room.name
                            ? `press to ${drawn.has(key(picked, room.name)) ? "unpair from" : "pair with"} ${picked}`
                            : "press, then press another room to pair or unpair them") }, svg);
    el("circle", { cx: x, cy: y, r: radius(room), fill: roomFill(room.type) }, g);
    const label = el("text", { x, y: y + 4, "text-anchor": "middle" }, g);
    label.textContent = room.name;
    const press = () => {
      if (!picked || picked === room.name) {
        picked = picked === room.name ? null : room.name;
        drawBubbles(rooms, pairs, onToggle);
        $("bubble-note").textContent = picked
          ? `${picked} picked: press the room to pair it with (or unpair it from).` : "";
        $("bubbles").querySelector(`[data-room='${CSS.escape(room.name)}']`)?.focus();
        return;
      }
      const a = picked;
      picked = null;
      const on = !drawn.has(key(a, room.name));
      $("bubble-note").textContent = `${a} and ${room.name} ${on ? "paired" : "unpaired"}.`;
      onToggle(a, room.name, on);
      $("bubbles").querySelector(`[data-room='${CSS.escape(room.name)}']`)?.focus();
    };
    g.addEventListener("click", press);
    g.addEventListener("keydown", (event) => {
      if (event.key !== "Enter" && event.key !== " ") return;
      event.preventDefault();
      press();
    });
  }
  if (focused) svg.querySelector(`[data-room='${CSS.escape(focused)}']`)?.focus();
}
