// The JSON view of the brief: compact pretty-printing, and a syntax error shown at its
// line (numbered, marked, and selected in the text box).

const $ = (id) => document.getElementById(id);

/** JSON on as few lines as stay readable: short arrays and objects (points, sizes,
 * whole rooms) on one line, longer ones broken over lines. */
const TEXT_WIDTH = 60; // about the text box's width

function inline(value) {
  if (Array.isArray(value)) return `[${value.map(inline).join(", ")}]`;
  if (value && typeof value === "object") {
    const members = Object.entries(value).map(([k, v]) => `${JSON.stringify(k)}: ${inline(v)}`);
    return `{${members.join(", ")}}`;
  }
  return JSON.stringify(value);
}

export function prettyJson(value, indent = "") {
  const line = inline(value);
  if (value === null || typeof value !== "object" || indent.length + line.length <= TEXT_WIDTH) {
    return line;
  }
  const inner = `${indent}  `;
  const parts = Array.isArray(value)
    ? value.map((v) => inner + prettyJson(v, inner))
    : Object.entries(value).map(([k, v]) => `${inner}${JSON.stringify(k)}: ${prettyJson(v, inner)}`);
  const [open, close] = Array.isArray(value) ? ["[", "]"] : ["{", "}"];
  return `${open}\n${parts.join(",\n")}\n${indent}${close}`;
}

/** A JSON syntax error with its line shown, numbered and marked, and selected in the box. */
export function showJsonError(err) {
  const text = $("problem").value;
  const message = String(err.message ?? err);
  let line = null;
  const at = /line (\d+) column (\d+)/.exec(message);
  const position = /position (\d+)/.exec(message);
  if (at) line = Number(at[1]);
  else if (position) line = text.slice(0, Number(position[1])).split("\n").length;
  else if (/end of JSON|Unterminated/i.test(message)) line = text.split("\n").length;
  const box = $("json-error");
  box.replaceChildren();
  const p = document.createElement("p");
  p.textContent = `Not valid JSON${line ? ` at line ${line}` : ""}: ${message}`;
  box.append(p);
  if (line) {
    const lines = text.split("\n");
    const pre = document.createElement("pre");
    for (let k = Math.max(1, line - 2); k <= Math.min(lines.length, line + 2); k++) {
      const span = document.createElement(k === line ? "mark" : "span");
      span.className = "json-line";
      span.dataset.line = String(k);
      span.textContent = `${String(k).padStart(4)}  ${lines[k - 1]}\n`;
      pre.append(span);
    }
    box.append(pre);
    const start = lines.slice(0, line - 1).reduce((n, l) => n + l.length + 1, 0);
    $("problem").setSelectionRange(start, start + (lines[line - 1]?.length ?? 0));
  }
  box.hidden = false;
  $("json-view").open = true;
  return line;
}
