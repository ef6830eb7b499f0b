// The verdict on a layout, in words an architect reads: one line saying whether the plan
// holds, a table of the rooms (target against actual area, walls, neighbours, reach),
// every check of the report with pass or fail, and for a failure what to try. It shows
// the report as the service wrote it: a check the report failed is never shown as held.
// The areas and sides shown are the polygons' own (bounding boxes for the sides).

import { TERMINATION_WORDS, whatToTry } from "./words.js";

const $ = (id) => document.getElementById(id);
const fmt = (value, digits = 2) => (value == null ? "–" : Number(value).toFixed(digits));
/** A room's area this far from its target reads as off target. */
export const AREA_TOLERANCE = 0.15;
/** An uncovered area below this (m²) is rounding, not a gap on the plan. */
const NO_GAP_M2 = 0.01;

/** Rooms of a layout or of every floor of a building, each with its floor id. */
export function placedRooms(layout) {
  if (!layout) return [];
  if (layout.floors) return layout.floors.flatMap((f) => f.rooms.map((r) => ({ ...r, floor: f.id })));
  return layout.rooms ?? [];
}

/** Room objects of a (plain, expanded) problem, by `floor/id` or `id`. */
export function briefRooms(problem) {
  const out = {};
  for (const room of problem?.rooms ?? []) if (room && typeof room === "object") out[room.id] = room;
  for (const floor of problem?.floors ?? []) {
    for (const room of floor.rooms ?? []) out[`${floor.id}/${room.id}`] = room;
  }
  return out;
}

const targetArea = (room) => (room?.target_size ? room.target_size[0] * room.target_size[1] : null);

function sides(polygon) {
  const xs = polygon.map((p) => p[0]);
  const ys = polygon.map((p) => p[1]);
  return [Math.max(...xs) - Math.min(...xs), Math.max(...ys) - Math.min(...ys)];
}

/** Per room: target and actual area, their difference, and the checks naming it. */
export function roomFigures(problem, layout) {
  const brief = briefRooms(problem);
  const checks = layout?.report?.constraints ?? [];
  const unreachable = new Set(layout?.report?.circulation?.unreachable ?? []);
  const hasReach = Boolean(layout?.report?.circulation);
  return placedRooms(layout).map((room) => {
    const key = room.floor ? `${room.floor}/${room.id}` : room.id;
    const target = targetArea(brief[key]);
    const own = checks.filter((c) => c.rooms?.includes(room.id)
      && (!room.floor || !c.floor || c.floor === room.floor));
    const verdict = (kind) => {
      const list = own.filter((c) => c.kind === kind);
      return list.length ? { ok: list.every((c) => c.satisfied), list } : null;
    };
    return {
      id: room.id, key, type: room.type, target, area: room.area,
      diff: target ? (room.area - target) / target : null,
      sides: sides(room.polygon), size: verdict("size"), exterior: verdict("boundary"),
      adjacency: verdict("adjacency"),
      reachable: hasReach ? !unreachable.has(room.id) : null,
    };
  });
}

/** The mean of |actual - target| / target over rooms with a target (null without). */
export function meanAreaError(problem, layout) {
  const diffs = roomFigures(problem, layout).filter((r) => r.diff != null).map((r) => Math.abs(r.diff));
  return diffs.length ? diffs.reduce((a, b) => a + b, 0) / diffs.length : null;
}

/** A relative difference as a signed percentage ("+41 %", "−19 %", "0 %"). */
export function percent(diff) {
  const value = Math.round(100 * diff);
  return value === 0 ? "0 %" : `${value > 0 ? "+" : "−"}${Math.abs(value)} %`;
}

function mark(cell, ok, text) {
  cell.textContent = text ?? (ok ? "✓" : "✗");
  cell.className = ok ? "yes" : "no";
  cell.dataset.ok = String(ok);
}

function fillRoomTable(figures) {
  const body = $("room-table").querySelector("tbody");
  body.replaceChildren();
  for (const r of figures) {
    const tr = document.createElement("tr");
    tr.dataset.room = r.id;
    const cells = [r.id, r.type, r.target == null ? "–" : fmt(r.target, 1), fmt(r.area, 1), "",
                   `${fmt(r.sides[0], 1)} × ${fmt(r.sides[1], 1)}`, "", "", "", ""];
    for (const text of cells) {
      const td = document.createElement("td");
      td.textContent = text;
      tr.append(td);
    }
    const [, , , , diff, , size, exterior, adjacency, reach] = tr.children;
    tr.children[0].setAttribute("scope", "row");
    if (r.diff == null) diff.textContent = "–";
    else mark(diff, Math.abs(r.diff) <= AREA_TOLERANCE, percent(r.diff));
    for (const [cell, v] of [[size, r.size], [exterior, r.exterior], [adjacency, r.adjacency]]) {
      if (!v) cell.textContent = "–";
      else {
        mark(cell, v.ok);
        cell.title = v.list.map((c) => c.detail).filter(Boolean).join("; ");
      }
    }
    if (r.reachable == null) reach.textContent = "–";
    else mark(reach, r.reachable);
    body.append(tr);
  }
}

function fillChecks(checks) {
  const failed = checks.filter((c) => !c.satisfied);
  const box = $("checks");
  $("checks-summary").textContent = checks.length
    ? `All ${checks.length} checks: ${checks.length - failed.length} pass, ${failed.length} fail`
    : "No checks (no layout)";
  const list = $("check-list");
  list.replaceChildren();
  for (const c of [...failed, ...checks.filter((x) => x.satisfied)]) {
    const li = document.createElement("li");
    const goal = c.kind === "coverage" || c.kind === "aisle_access" || c.soft;
    li.className = c.satisfied ? "pass" : goal ? "goal" : "fail";
    li.dataset.kind = c.kind;
    li.dataset.satisfied = String(c.satisfied);
    const where = c.floor ? ` on floor ${c.floor}` : "";
    const state = c.satisfied ? "pass" : goal ? "missed (a goal, not a rule)" : "FAIL";
    li.textContent = `${state}: ${c.kind} — ${(c.rooms ?? []).join(", ")}${where}${c.detail ? `: ${c.detail}` : ""}`;
    list.append(li);
  }
  box.open = failed.length > 0;
}

function row(list, term, value, verdict = null) {
  const dt = document.createElement("dt");
  dt.textContent = term;
  const dd = document.createElement("dd");
  dd.textContent = value;
  if (verdict !== null) dd.className = verdict === "partial" ? "partial" : verdict ? "yes" : "no";
  dd.dataset.term = term;
  list.append(dt, dd);
}

/** The one-line verdict, and the `valid` and `coverage` rows as the checks say them. */
function verdictOf(report, figures) {
  const checks = report.constraints ?? [];
  const failed = checks.filter((c) => !c.satisfied);
  const hard = failed.filter((c) => !(c.kind === "coverage" || c.kind === "aisle_access" || c.soft));
  const goals = failed.filter((c) => !hard.includes(c));
  const off = figures.filter((r) => r.diff != null && Math.abs(r.diff) > AREA_TOLERANCE);
  const offText = off.map((r) => `${r.id} ${percent(r.diff)}`).join(", ");
  const gap = report.uncovered_area ?? 0;
  let line;
  if (!report.valid || hard.length) {
    const rooms = [...new Set(hard.flatMap((c) => c.rooms ?? []))];
    line = `Not a valid plan: ${hard.length || "some"} rule(s) broken`
      + (rooms.length ? ` (${rooms.slice(0, 6).join(", ")})` : "") + ".";
  } else {
    line = `A valid plan: all ${checks.length - goals.length} rules hold`;
    if (goals.length) line += `, but ${goals.map((c) => c.kind === "coverage" ? "the floor is not all covered" : `${c.kind} is missed`).join(" and ")}`;
    line += off.length ? `; ${off.length} room(s) far from their target area (${offText}).`
      : figures.some((r) => r.diff != null) ? `; every room within ${100 * AREA_TOLERANCE} % of its target area.` : ".";
  }
  if (gap >= NO_GAP_M2 && !goals.some((c) => c.kind === "coverage")) {
    line += ` ${fmt(gap)} m² of floor is left uncovered (red on the plan).`;
  }
  const valid = !report.valid || hard.length ? ["no", false]
    : goals.length ? [`yes for the rules; ${goals.length} goal(s) missed`, "partial"] : ["yes", true];
  const coverage = [`${(100 * report.coverage).toFixed(1)} %` + (gap >= NO_GAP_M2 ? `, ${fmt(gap)} m² uncovered` : ""),
                    goals.some((c) => c.kind === "coverage") ? false : gap >= NO_GAP_M2 ? "partial" : true];
  return { line, valid, coverage };
}

/**
 * The summary of `layout` (a job's result or one of its variants) of `job` with record
 * `info`; `problem` is the brief as solved (templates expanded).
 */
export function showVerdict({ job, info, layout, problem, variant = null }) {
  const list = $("summary-list");
  list.replaceChildren();
  const report = layout?.report;
  const placed = placedRooms(layout);
  row(list, "status", info.status, info.status === "succeeded");
  row(list, "termination", report?.termination ?? info.termination ?? "–");
  let line = "";
  const figures = report ? roomFigures(problem, layout) : [];
  if (report && placed.length) {
    const v = verdictOf(report, figures);
    line = v.line;
    const brief = Object.keys(briefRooms(problem)).length;
    row(list, "coverage", v.coverage[0], v.coverage[1]);
    row(list, "valid", v.valid[0], v.valid[1]);
    row(list, "rooms placed", `${placed.length} of ${Math.max(brief, placed.length)}`);
    if (layout.floors) {
      row(list, "floors", layout.floors.map((f) => `${f.name}${f.report.valid ? "" : " (invalid)"}`)
        .join(", ") + " (the plan shows the first)");
    }
    row(list, "objective", fmt(report.objective));
    row(list, "solve time", `${fmt(report.solve_time, 1)} s`);
    row(list, "levels", String(report.levels));
    if (report.circulation) {
      const c = report.circulation;
      row(list, "reachable", c.reachable ? "every room" : `not: ${c.unreachable.join(", ")}`, c.reachable);
    }
  }
  if (variant != null) row(list, "variant", `#${variant + 1}`);
  const termination = report?.termination ?? info.termination;
  const words = TERMINATION_WORDS[termination];
  if (!placed.length || !report?.valid) {
    const conflict = info.error?.conflict ?? report?.infeasibility?.conflict;
    const findings = info.error?.findings ?? report?.infeasibility?.findings ?? [];
    const tips = whatToTry({ termination, conflict, findings,
                             timeLimit: job.problem?.options?.time_limit ?? info.time_limit });
    line = (placed.length ? line : `No plan: ${words ?? termination ?? info.status}.`)
      + ` What to try: ${tips.join(" ")}`;
    $("try-list").replaceChildren(...tips.map((t) => Object.assign(document.createElement("li"), { textContent: t })));
  } else {
    $("try-list").replaceChildren();
  }
  $("verdict").textContent = line + (words && placed.length && report?.valid ? ` (${words}.)` : "");
  $("room-table").hidden = !figures.length;
  fillRoomTable(figures);
  fillChecks(report?.constraints ?? []);
  $("summary").hidden = false;
}

/** The progress strip from the final report, so that the two never disagree. */
export function progressFromReport(report) {
  if (!report) return;
  $("objective").textContent = fmt(report.objective);
  $("level").textContent = String(report.levels ?? "–");
  $("bound").textContent = fmt(report.bound);
  if (report.solve_time != null) $("elapsed").textContent = `${Number(report.solve_time).toFixed(1)} s`;
}
