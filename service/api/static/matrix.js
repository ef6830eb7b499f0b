// Adjacencies picked per pair: a matrix of the named rooms, one checkbox per pair (the
// upper triangle), ticked where the brief asks the two to share a wall. It is a view of
// the rooms' "Next to" fields: a tick writes the pair there, an untick removes it.

const $ = (id) => document.getElementById(id);
const key = (a, b) => (a < b ? `${a}|${b}` : `${b}|${a}`);

/**
 * Draws the matrix of `names` with the pairs of `pairs` ([a, b] lists) ticked;
 * `onToggle(a, b, on)` when a box changes. Focus stays on the box that was toggled.
 */
export function drawMatrix(names, pairs, onToggle) {
  const table = $("adjacency-matrix");
  const focused = document.activeElement?.closest?.("#adjacency-matrix")
    ? document.activeElement.dataset.pair : null;
  table.replaceChildren();
  const unique = [...new Set(names.filter(Boolean))];
  $("matrix-box").hidden = unique.length < 2;
  if (unique.length < 2) return;
  const ticked = new Set(pairs.map(([a, b]) => key(a, b)));
  const caption = document.createElement("caption");
  caption.textContent = "Share a wall: tick a pair";
  const head = document.createElement("tr");
  head.append(document.createElement("td"));
  for (const name of unique.slice(1)) {
    const th = document.createElement("th");
    th.scope = "col";
    th.className = "col";
    th.textContent = name;
    head.append(th);
  }
  const thead = document.createElement("thead");
  thead.append(head);
  const body = document.createElement("tbody");
  unique.slice(0, -1).forEach((a, i) => {
    const tr = document.createElement("tr");
    const th = document.createElement("th");
    th.scope = "row";
    th.textContent = a;
    tr.append(th);
    unique.slice(1).forEach((b, j) => {
      const td = document.createElement("td");
      if (j >= i) {
        const box = document.createElement("input");
        box.type = "checkbox";
        box.checked = ticked.has(key(a, b));
        box.dataset.pair = key(a, b);
        box.dataset.a = a;
        box.dataset.b = b;
        box.dataset.testid = "adjacency-pair";
        box.setAttribute("aria-label", `${a} next to ${b}`);
        box.addEventListener("change", () => onToggle(a, b, box.checked));
        td.append(box);
      }
      tr.append(td);
    });
    body.append(tr);
  });
  table.append(caption, thead, body);
  if (focused) table.querySelector(`[data-pair='${CSS.escape(focused)}']`)?.focus();
}
