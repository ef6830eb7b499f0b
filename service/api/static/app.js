// The page: pick, paste or upload a problem; submit it; follow the job's event stream,
// redrawing the incumbent; then show the report and the downloads. Every call goes to
// the public API, relative to the page, so the page also works behind a path prefix.

import { followEvents } from "./events.js";
import { exploreResult, setupExplore } from "./explore.js";
import { drawPlan } from "./plan.js";

const $ = (id) => document.getElementById(id);
const TERMINAL = new Set(["succeeded", "failed", "canceled"]);
const KEY_STORAGE = "floorplan.api-key";
const JOB_STORAGE = "floorplan.job"; // the job on screen, followed again after a reload
const CLOCK_MS = 200;
// The solver's phases (solver/pipeline/solve.py Phase) in words.
const PHASES = {
  relaxation: "size window tried", level: "level started", subdomain: "sub-domain solved",
  incumbent: "better layout found", done: "done",
};

const state = {
  job: null,          // {id, problem}: the job on screen
  status: null,       // its last known status
  abort: null,        // AbortController of the event stream
  elapsed: null,      // {seconds, at}: the solver's last elapsed time and when it came
};

// Calling the API.

class ApiProblem extends Error {
  /** An RFC 9457 problem document, or one made up for a failure without one. */
  constructor(doc) {
    super(doc.detail || doc.title);
    this.doc = doc;
  }
}

function authHeaders() {
  const key = $("api-key").value.trim();
  return key ? { Authorization: `Bearer ${key}` } : {};
}

async function problemOf(response) {
  const type = response.headers.get("content-type") || "";
  if (type.includes("json")) {
    try {
      return await response.json();
    } catch { /* not JSON after all: fall through */ }
  }
  return { title: response.statusText || "Error", status: response.status,
           detail: (await response.text().catch(() => "")).slice(0, 300) };
}

async function api(path, { method = "GET", body } = {}) {
  const headers = { ...authHeaders() };
  if (body !== undefined) headers["Content-Type"] = "application/json";
  let response;
  try {
    response = await fetch(path, { method, headers, body, cache: "no-store" });
  } catch (err) {
    throw new ApiProblem({ title: "The server did not answer", detail: String(err) });
  }
  if (!response.ok) throw new ApiProblem(await problemOf(response));
  return response.json();
}

// Messages: errors as problem documents, with every field path listed.

function showMessage({ title, detail = "", items = [], ok = false }) {
  const box = $("messages");
  box.replaceChildren();
  box.classList.toggle("ok", ok);
  const heading = document.createElement("h3");
  heading.textContent = title;
  box.append(heading);
  if (detail) {
    const p = document.createElement("p");
    p.textContent = detail;
    box.append(p);
  }
  if (items.length) {
    const list = document.createElement("ul");
    for (const [code, text] of items) {
      const li = document.createElement("li");
      if (code) {
        const c = document.createElement("code");
        c.textContent = code;
        li.append(c, ": ");
      }
      li.append(text);
      list.append(li);
    }
    box.append(list);
  }
  box.hidden = false;
}

function clearMessage() {
  $("messages").hidden = true;
}

function showProblem(err) {
  const doc = err instanceof ApiProblem ? err.doc : { title: "Error", detail: String(err) };
  const status = doc.status ? ` (${doc.status})` : "";
  showMessage({ title: `${doc.title}${status}`, detail: doc.detail,
                items: (doc.errors || []).map((e) => [e.field, e.message]) });
  if (doc.status === 401) askForKey();
}

function askForKey() {
  const note = $("key-note");
  note.textContent = "This server requires an API key.";
  note.classList.add("required");
  $("key-box").open = true;
  $("api-key").focus();
}

// The problem: examples, files, the text box.

async function loadExamples() {
  try {
    const { data } = await api("v1/examples");
    const select = $("example");
    for (const example of data) {
      const option = new Option(`${example.name} (${example.rooms} rooms)`, example.name);
      select.append(option);
    }
  } catch (err) {
    console.warn("no examples:", err);
  }
}

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

function prettyJson(value, indent = "") {
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

async function pickExample() {
  const name = $("example").value;
  if (!name) return;
  try {
    $("problem").value = prettyJson(await api(`v1/examples/${encodeURIComponent(name)}`));
    clearMessage();
    previewProblem();
  } catch (err) {
    showProblem(err);
  }
}

async function readFile(file) {
  if (!file) return;
  $("problem").value = await file.text();
  $("example").value = "";
  clearMessage();
  previewProblem();
}

/** The text box as a problem, with the form's time limit and seed applied. */
function problemFromForm() {
  const text = $("problem").value.trim();
  if (!text) throw new ApiProblem({ title: "No problem yet",
                                    detail: "Pick an example, choose a file or paste JSON." });
  let problem;
  try {
    problem = JSON.parse(text);
  } catch (err) {
    throw new ApiProblem({ title: "The problem is not valid JSON", detail: err.message });
  }
  if (problem === null || typeof problem !== "object" || Array.isArray(problem)) {
    return problem; // the server names what is wrong with it
  }
  const options = { ...(problem.options || {}) };
  const timeLimit = $("time-limit").value;
  const seed = $("seed").value;
  if (timeLimit !== "") options.time_limit = Number(timeLimit);
  if (seed !== "") options.seed = Number(seed);
  const variants = $("variants").value;
  if (variants !== "") options.variants = Number(variants);
  return Object.keys(options).length ? { ...problem, options } : problem;
}

/** Draws the outline of what is in the text box, when it parses, before any solve. */
function previewProblem() {
  if (state.job && !TERMINAL.has(state.status)) return; // a solve is on screen
  try {
    const problem = JSON.parse($("problem").value);
    resetProgress();
    $("summary").hidden = true;
    drawPlan($("plan"), problem);
  } catch {
    /* half-typed JSON: keep the last drawing */
  }
}

// Following a job.

function setStatus(status) {
  state.status = status;
  $("status").textContent = status;
  const active = !TERMINAL.has(status);
  $("submit").disabled = active;
  $("cancel").disabled = !active;
}

function resetProgress() {
  for (const id of ["level", "subdomain", "objective", "bound", "elapsed"]) $(id).textContent = "–";
  $("phase").textContent = "";
  state.elapsed = null;
}

const fmt = (value, digits = 2) => (value == null ? "–" : Number(value).toFixed(digits));

function showProgress(p) {
  if (!p) return;
  if (p.level != null) $("level").textContent = p.level;
  if (p.subdomains) $("subdomain").textContent = `${p.subdomain ?? 0} / ${p.subdomains}`;
  if (p.objective != null) $("objective").textContent = fmt(p.objective);
  if (p.dual_bound != null) $("bound").textContent = fmt(p.dual_bound);
  if (p.elapsed != null) {
    state.elapsed = { seconds: p.elapsed, at: performance.now() };
    showElapsed();
  }
  $("phase").textContent = [PHASES[p.phase] ?? p.phase, p.detail].filter(Boolean).join(": ");
}

/** The solver's elapsed time, running on between events while the job runs. */
function showElapsed() {
  if (!state.elapsed) return;
  const running = state.status === "running";
  const since = running ? (performance.now() - state.elapsed.at) / 1000 : 0;
  $("elapsed").textContent = `${(state.elapsed.seconds + since).toFixed(1)} s`;
}

function onEvent({ type, data }) {
  let payload;
  try {
    payload = JSON.parse(data);
  } catch {
    return;
  }
  if (type === "status") {
    setStatus(payload.status);
    if (payload.detail) $("phase").textContent = payload.detail;
  } else if (type === "progress") {
    showProgress(payload);
  } else if (type === "incumbent") {
    showProgress(payload.progress);
    drawPlan($("plan"), ...oneFloor(state.job.problem, payload.layout), "incumbent");
  }
}

async function follow(job) {
  state.abort?.abort();
  const abort = new AbortController();
  state.abort = abort;
  state.job = job;
  try {
    sessionStorage.setItem(JOB_STORAGE, JSON.stringify(job));
  } catch (err) {
    console.warn("the job is too large to keep for a reload:", err);
  }
  setStatus("queued");
  resetProgress();
  $("summary").hidden = true;
  drawPlan($("plan"), job.problem);
  await followEvents(`v1/layouts/${job.id}/events`, {
    headers: authHeaders,
    onEvent,
    onProblem: async (response) => {
      if (response.status === 404) sessionStorage.removeItem(JOB_STORAGE); // deleted or purged
      showProblem(new ApiProblem(await problemOf(response)));
      setStatus("unknown");
      $("submit").disabled = false;
      $("cancel").disabled = true;
    },
    onReconnect: (ms) => { $("phase").textContent = `connection lost; retrying in ${ms / 1000} s`; },
    isFinished: () => TERMINAL.has(state.status),
    signal: abort.signal,
  });
  if (!abort.signal.aborted && TERMINAL.has(state.status)) await finish(job);
}

/** The job has ended: its final record, its layout and report, the downloads. */
async function finish(job) {
  let info;
  let layout = null;
  try {
    info = await api(`v1/layouts/${job.id}`);
    setStatus(info.status);
    showProgress(info.progress);
    layout = await api(`v1/layouts/${job.id}/result`);
  } catch (err) {
    if (!(err instanceof ApiProblem && err.doc.status === 404)) showProblem(err);
  }
  if (layout && allRooms(layout).length) {
    drawPlan($("plan"), ...oneFloor(job.problem, layout), "result");
  }
  if (info) showSummary(job, info, layout);
  exploreResult(job.problem, layout);
}

/** Every room of a layout: its rooms, or those of every floor of a building. */
function allRooms(layout) {
  return layout.floors ? layout.floors.flatMap((f) => f.rooms) : layout.rooms;
}

/** What the plan shows: the problem and layout as they are, or for a building of
 * several storeys its first floor (an incumbent's: the floor being solved), with that
 * floor's outline, obstacles and entrance. */
function oneFloor(problem, layout) {
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

function row(list, term, value, verdict = null) {
  const dt = document.createElement("dt");
  dt.textContent = term;
  const dd = document.createElement("dd");
  dd.textContent = value;
  if (verdict !== null) dd.className = verdict ? "yes" : "no";
  dd.dataset.term = term;
  list.append(dt, dd);
}

function showSummary(job, info, layout) {
  const list = $("summary-list");
  list.replaceChildren();
  row(list, "status", info.status, info.status === "succeeded");
  row(list, "termination", info.termination ?? "–");
  const report = layout?.report;
  const placed = layout ? allRooms(layout) : [];
  if (report && placed.length) {
    const floors = job.problem.floors ?? [];
    const total = (job.problem.rooms?.length ?? 0) +
      floors.reduce((n, f) => n + (f.rooms?.length ?? 0) +
        (job.problem.vertical ?? []).filter((v) => !v.floors || v.floors.includes(f.id)).length,
      0) || placed.length;
    row(list, "coverage", `${(100 * report.coverage).toFixed(1)} %`, report.coverage >= 0.99);
    row(list, "valid", report.valid ? "yes" : "no", report.valid);
    row(list, "rooms placed", `${placed.length} of ${total}`);
    if (layout.floors) {
      row(list, "floors", layout.floors.map((f) => `${f.name}${f.report.valid ? "" : " (invalid)"}`)
        .join(", ") + " (the plan shows the first)");
    }
    row(list, "objective", fmt(report.objective));
    row(list, "solve time", `${fmt(report.solve_time, 1)} s`);
    row(list, "levels", String(report.levels));
    if (report.circulation) {
      const c = report.circulation;
      row(list, "reachable", c.reachable ? "every room" : `not: ${c.unreachable.join(", ")}`,
          c.reachable);
    }
  }
  const failed = $("failed-checks");
  failed.replaceChildren();
  for (const check of (report?.constraints ?? []).filter((c) => !c.satisfied)) {
    const li = document.createElement("li");
    const where = check.floor ? ` on floor ${check.floor}` : "";
    li.textContent = `${check.kind} (${check.rooms.join(", ")})${where}${check.detail ? ": " + check.detail : ""}`;
    failed.append(li);
  }
  if (info.error) {
    showMessage({ title: `No layout: ${info.error.code}`, detail: info.error.message,
                  items: (info.error.findings ?? []).map((f) => ["", f]) });
  } else if (report?.infeasibility) {
    showMessage({ title: "No layout", detail: report.infeasibility.reason,
                  items: report.infeasibility.findings.map((f) => ["", f]) });
  }
  setDownloads(job, placed.length > 0);
  $("summary").hidden = false;
}

// Downloads: real links (to copy or open), but a click fetches the file itself, with
// the API key when there is one, and saves it under the problem's name: the server
// names its files after the job id, and a plain link could not send the key.

function setDownloads(job, available) {
  const base = (job.problem.name || "layout").replace(/[^\w.-]+/g, "_");
  for (const link of document.querySelectorAll("#downloads a")) {
    const format = link.dataset.format;
    if (available) {
      link.href = `v1/layouts/${job.id}/result?format=${format}`;
      link.download = `${base}.${format === "json" ? "layout.json" : format}`;
    } else {
      link.removeAttribute("href");
    }
  }
}

async function downloadFile(event) {
  const link = event.target.closest("a");
  if (!link?.href || event.ctrlKey || event.metaKey || event.shiftKey) return;
  event.preventDefault();
  try {
    const response = await fetch(link.href, { headers: authHeaders(), cache: "no-store" });
    if (!response.ok) throw new ApiProblem(await problemOf(response));
    const url = URL.createObjectURL(await response.blob());
    const save = document.createElement("a");
    save.href = url;
    save.download = link.download;
    document.body.append(save);
    save.click();
    save.remove();
    setTimeout(() => URL.revokeObjectURL(url), 60_000);
  } catch (err) {
    showProblem(err);
  }
}

// The buttons.

async function submit(event) {
  event.preventDefault();
  clearMessage();
  try {
    await send(problemFromForm());
  } catch (err) {
    showProblem(err);
  }
}

/** Posts `problem` as a job and follows it. */
async function send(problem) {
  try {
    $("submit").disabled = true;
    const job = await api("v1/layouts", { method: "POST", body: JSON.stringify(problem) });
    follow({ id: job.id, problem });
  } catch (err) {
    $("submit").disabled = false;
    throw err;
  }
}

/** An edit of the explore panel: shown in the text box, then sent as a job. */
async function resubmit(problem) {
  clearMessage();
  $("problem").value = prettyJson(problem);
  try {
    await send(problem);
  } catch (err) {
    showProblem(err);
    exploreResult(problem, null);
  }
}

async function validate() {
  clearMessage();
  try {
    const result = await api("v1/validate", {
      method: "POST", body: JSON.stringify(problemFromForm()),
    });
    if (result.valid) {
      showMessage({ title: "No problem found", ok: true,
                    detail: "The problem is well formed and no cheap impossibility was found." });
    } else {
      showMessage({
        title: result.errors.length ? `${result.errors.length} invalid field(s)`
                                    : "No layout can exist",
        items: [...result.errors.map((e) => [e.field, e.message]),
                ...result.findings.map((f) => ["", f])],
      });
    }
  } catch (err) {
    showProblem(err);
  }
}

async function cancel() {
  if (!state.job) return;
  $("cancel").disabled = true;
  $("phase").textContent = "cancelling: the best layout so far becomes the result";
  try {
    await api(`v1/layouts/${state.job.id}/cancel`, { method: "POST" });
  } catch (err) {
    showProblem(err);
  }
}

/** Before anything else: does this server want a key we do not have? */
async function probeKey() {
  try {
    await api("v1/layouts?limit=1");
  } catch (err) {
    if (err instanceof ApiProblem && err.doc.status === 401) askForKey();
  }
}

function start() {
  $("api-key").value = sessionStorage.getItem(KEY_STORAGE) ?? "";
  $("api-key").addEventListener("input", () => {
    sessionStorage.setItem(KEY_STORAGE, $("api-key").value.trim());
  });
  $("example").addEventListener("change", pickExample);
  $("file").addEventListener("change", (e) => readFile(e.target.files[0]));
  const box = $("problem");
  box.addEventListener("input", previewProblem);
  box.addEventListener("dragover", (e) => { e.preventDefault(); box.classList.add("dragging"); });
  box.addEventListener("dragleave", () => box.classList.remove("dragging"));
  box.addEventListener("drop", (e) => {
    e.preventDefault();
    box.classList.remove("dragging");
    readFile(e.dataTransfer.files[0]);
  });
  $("problem-form").addEventListener("submit", submit);
  $("validate").addEventListener("click", validate);
  $("cancel").addEventListener("click", cancel);
  $("downloads").addEventListener("click", downloadFile);
  setInterval(showElapsed, CLOCK_MS);
  setupExplore(resubmit);

  loadExamples();
  probeKey();
  const saved = sessionStorage.getItem(JOB_STORAGE);
  if (saved) {
    const job = JSON.parse(saved);
    $("problem").value = prettyJson(job.problem);
    follow(job); // replays its events from the start, or shows how it ended
  }
}

start();
