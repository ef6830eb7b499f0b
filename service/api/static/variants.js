// The variants of a result side by side: per variant its coverage, how far its rooms are
// from their target areas, its score (Eq. 12), whether it is valid and how much its
// topology differs from the best; a star and a name to keep favourites, stored in this
// browser per job (so they are there again after a reload), and a button to show it.

import { AREA_TOLERANCE, meanAreaError, roomFigures } from "./verdict.js";

const $ = (id) => document.getElementById(id);
const STORAGE = "floorplan.variants"; // {jobId: {index: {star, name}}}

function all() {
  try {
    return JSON.parse(localStorage.getItem(STORAGE) ?? "{}") ?? {};
  } catch {
    return {};
  }
}

/** The star and name kept for variant `k` of job `jobId`. */
export function favourite(jobId, k) {
  return all()[jobId]?.[k] ?? {};
}

function keep(jobId, k, fields) {
  const stored = all();
  const job = stored[jobId] ?? {};
  job[k] = { ...(job[k] ?? {}), ...fields };
  stored[jobId] = job;
  try {
    localStorage.setItem(STORAGE, JSON.stringify(stored));
  } catch (err) {
    console.warn("favourites not kept:", err);
  }
}

const pct = (v, digits = 0) => (v == null ? "–" : `${(100 * v).toFixed(digits)} %`);

function cell(tr, text, className = "") {
  const td = document.createElement("td");
  td.textContent = text;
  if (className) td.className = className;
  tr.append(td);
  return td;
}

/** Fills the table for `view` ({job, problem, layouts, picked}); `pick(k)` shows one,
 * `kept()` after a star or a name changed (the thumbnails' captions name them too). */
export function drawVariantsTable(view, pick, kept = () => {}) {
  const box = $("variants-box");
  const body = $("variants-table").querySelector("tbody");
  body.replaceChildren();
  box.hidden = view.layouts.length < 2;
  if (box.hidden) return;
  const jobId = view.job?.id ?? "";
  view.layouts.forEach((layout, k) => {
    const report = layout.report ?? {};
    const stored = favourite(jobId, k);
    const tr = document.createElement("tr");
    tr.dataset.testid = "variant-row";
    tr.dataset.index = String(k);
    if (k === view.picked) tr.className = "picked";

    const star = document.createElement("button");
    star.type = "button";
    star.className = "star";
    star.dataset.testid = "variant-star";
    star.textContent = stored.star ? "★" : "☆";
    star.setAttribute("aria-pressed", String(Boolean(stored.star)));
    star.setAttribute("aria-label", `star variant ${k + 1}`);
    star.addEventListener("click", () => {
      const on = star.getAttribute("aria-pressed") !== "true";
      keep(jobId, k, { star: on });
      star.textContent = on ? "★" : "☆";
      star.setAttribute("aria-pressed", String(on));
      kept();
    });
    const name = document.createElement("input");
    name.type = "text";
    name.size = 10;
    name.value = stored.name ?? "";
    name.placeholder = `variant ${k + 1}`;
    name.dataset.testid = "variant-name";
    name.setAttribute("aria-label", `name of variant ${k + 1}`);
    name.addEventListener("input", () => keep(jobId, k, { name: name.value }));
    name.addEventListener("change", kept);
    const first = document.createElement("td");
    first.append(star);
    const second = document.createElement("td");
    second.append(name);
    tr.append(first, second);

    const th = document.createElement("th");
    th.scope = "row";
    th.textContent = `#${k + 1}`;
    tr.append(th);
    cell(tr, pct(report.coverage, 1)).dataset.value = String(report.coverage ?? "");
    const error = meanAreaError(view.problem, layout);
    const off = roomFigures(view.problem, layout)
      .filter((r) => r.diff != null && Math.abs(r.diff) > AREA_TOLERANCE).length;
    cell(tr, error == null ? "–" : `${pct(error)}${off ? ` (${off} off)` : ""}`);
    cell(tr, report.objective == null ? "–" : Number(report.objective).toFixed(2))
      .dataset.value = String(report.objective ?? "");
    const failed = (report.constraints ?? []).filter((c) => !c.satisfied
      && !(c.kind === "coverage" || c.kind === "aisle_access" || c.soft)).length;
    const valid = report.valid !== false && !failed;
    cell(tr, valid ? "✓" : `✗ ${failed || ""}`.trim(), valid ? "yes" : "no").dataset.ok = String(valid);
    const difference = report.variant?.difference?.[0];
    cell(tr, k === 0 || difference == null ? "–" : pct(difference));

    const show = document.createElement("button");
    show.type = "button";
    show.textContent = k === view.picked ? "shown" : "show";
    show.setAttribute("aria-pressed", String(k === view.picked));
    show.setAttribute("aria-label", `show variant ${k + 1}`);
    show.dataset.testid = "variant-show";
    show.addEventListener("click", () => pick(k));
    const last = document.createElement("td");
    last.append(show);
    tr.append(last);
    body.append(tr);
  });
}
