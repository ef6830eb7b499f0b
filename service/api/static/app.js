// The page: pick, paste or upload a problem; submit it; follow the job's event stream,
// redrawing the incumbent; then show the report and the downloads. Every call goes to
// the public API, relative to the page, so the page also works behind a path prefix.

import { api, ApiProblem, askForKey, authHeaders, clearMessage, problemOf, showMessage,
         showProblem, withHints } from "./api.js";
import { loadBrief, setupBrief, showFieldErrors, STARTERS } from "./brief.js";
import { followEvents } from "./events.js";
import { exploreResult, setupExplore } from "./explore.js";
import { allRooms, drawPlan, oneFloor } from "./plan.js";
import { progressFromReport, showVerdict } from "./verdict.js";
import { prettyJson, showJsonError } from "./jsonview.js";
import { listSaved, saveBrief, savedBrief } from "./saved.js";
import { phaseWords, STATUS_WORDS } from "./words.js";

const $ = (id) => document.getElementById(id);
const TERMINAL = new Set(["succeeded", "failed", "canceled"]);
const KEY_STORAGE = "floorplan.api-key";
const JOB_STORAGE = "floorplan.job"; // the job on screen, followed again after a reload
const CLOCK_MS = 200;
const CHECK_DELAY_MS = 600; // validation as you type, once typing pauses

const state = {
  job: null,          // {id, problem}: the job on screen
  status: null,       // its last known status
  abort: null,        // AbortController of the event stream
  elapsed: null,      // {seconds, at}: the solver's last elapsed time and when it came
  checkTimer: null,   // the pending validation as you type
  checks: 0,          // validations sent: only the newest answer is shown
};

// The problem: examples, files, the text box.

async function loadExamples() {
  try {
    const select = $("example");
    const templates = document.createElement("optgroup");
    templates.label = "Residential template";
    for (const [value, { title }] of Object.entries(STARTERS)) templates.append(new Option(title, value));
    select.append(templates);
    listSaved(select);
    const { data } = await api("v1/examples");
    for (const example of data) {
      const option = new Option(`${example.name} (${example.rooms} rooms)`, example.name);
      select.append(option);
    }
  } catch (err) {
    console.warn("no examples:", err);
  }
}

async function pickExample() {
  const name = $("example").value;
  if (!name) return;
  try {
    const brief = name in STARTERS ? structuredClone(STARTERS[name].brief)
      : savedBrief(name) ?? await api(`v1/examples/${encodeURIComponent(name)}`);
    clearMessage();
    loadBrief(brief);
  } catch (err) {
    showProblem(err);
  }
}

async function readFile(file) {
  if (!file) return;
  $("problem").value = await file.text();
  $("example").value = "";
  clearMessage();
  jsonEdited();
}

/** The brief changed in the form (or was loaded): the JSON view follows. */
function briefChanged(brief, origin) {
  if (origin !== "json") {
    $("problem").value = prettyJson(brief);
    $("json-error").hidden = true;
  }
  previewProblem();
  scheduleCheck();
}

/** The JSON view edited: the form follows when it parses, else the line is shown. */
function jsonEdited() {
  try {
    const brief = JSON.parse($("problem").value);
    $("json-error").hidden = true;
    loadBrief(brief, true);
    briefChanged(brief, "json");
  } catch (err) {
    showJsonError(err);
  }
}

/** Validation as you type: the refused fields on their inputs, findings below. */
function scheduleCheck() {
  clearTimeout(state.checkTimer);
  state.checkTimer = setTimeout(checkAsYouType, CHECK_DELAY_MS);
}

async function checkAsYouType() {
  let problem;
  try {
    problem = problemFromForm();
  } catch {
    return;
  }
  const mine = ++state.checks;
  try {
    const result = await api("v1/validate", { method: "POST", body: JSON.stringify(problem) });
    if (mine !== state.checks) return;
    const rest = showFieldErrors(result.errors);
    const box = $("brief-findings");
    box.replaceChildren();
    const items = [...withHints(rest).map(([f, m]) => `${f}: ${m}`), ...result.findings];
    if (items.length) {
      const list = document.createElement("ul");
      for (const item of items) list.append(Object.assign(document.createElement("li"), { textContent: item }));
      box.append(list);
    }
  } catch { /* the server says why on Solve or Check only */ }
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
    const line = showJsonError(err);
    throw new ApiProblem({ title: "The problem is not valid JSON",
                           detail: `${line ? `line ${line}: ` : ""}${err.message}` });
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
  $("status").dataset.job = state.job?.id ?? ""; // which job the status is of
  $("status-words").textContent = STATUS_WORDS[status] ?? "";
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
  $("phase").textContent = phaseWords(p);
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
  progressFromReport(layout?.report);
  if (layout && allRooms(layout).length) {
    drawPlan($("plan"), ...oneFloor(job.problem, layout), "result");
  }
  if (!info) return;
  const problem = await expanded(job.problem);
  const explored = exploreResult(job, info, layout, problem);
  if (explored === "retry") return; // a wider edit is on its way: it reports
  if (!explored) {
    showVerdict({ job, info, layout, problem });
    setDownloads(job, Boolean(layout && allRooms(layout).length));
  }
  explainFailure(info, layout);
}

/** The brief as the server solves it: a templated one expanded (by the service's own
 * validation), a plain one as it is. */
async function expanded(problem) {
  if (!problem?.template) return problem;
  try {
    const result = await api("v1/validate", { method: "POST", body: JSON.stringify(problem) });
    return result.problem ?? problem;
  } catch {
    return problem;
  }
}

/** A view of the explore panel on screen: its report, downloads and brief. */
function showView(view) {
  const layout = view.layouts[view.picked];
  const variant = view.layouts.length > 1 ? view.picked : null;
  state.job = view.job;
  showVerdict({ job: view.job, info: view.info, layout, problem: view.problem, variant });
  progressFromReport(layout.report);
  setStatus(view.info.status);
  setDownloads(view.job, true, variant);
  if (view.briefText != null && $("problem").value !== view.briefText) {
    $("problem").value = view.briefText;
    try {
      loadBrief(JSON.parse(view.briefText), true);
    } catch { /* kept as text */ }
  }
}

function explainFailure(info, layout) {
  const report = layout?.report;
  if (info.error) {
    showMessage({ title: `No layout: ${info.error.code}`, detail: info.error.message,
                  items: (info.error.findings ?? []).map((f) => ["", f]) });
  } else if (report?.infeasibility) {
    showMessage({ title: "No layout", detail: report.infeasibility.reason,
                  items: report.infeasibility.findings.map((f) => ["", f]) });
  }
}

// Downloads: real links (to copy or open), but a click fetches the file itself, with
// the API key when there is one, and saves it under the problem's name: the server
// names its files after the job id, and a plain link could not send the key.

function setDownloads(job, available, variant = null) {
  const base = (job.problem.name || "layout").replace(/[^\w.-]+/g, "_")
    + (variant == null ? "" : `-variant-${variant + 1}`);
  for (const link of document.querySelectorAll("#downloads a")) {
    const format = link.dataset.format;
    if (available) {
      link.href = `v1/layouts/${job.id}/result?format=${format}`
        + (variant == null ? "" : `&variant=${variant}`);
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
  loadBrief(problem);
  try {
    await send(problem);
  } catch (err) {
    showProblem(err);
    exploreResult(null, null, null, problem);
  }
}

async function validate() {
  clearMessage();
  try {
    const result = await api("v1/validate", {
      method: "POST", body: JSON.stringify(problemFromForm()),
    });
    showFieldErrors(result.errors);
    if (result.valid) {
      showMessage({ title: "No problem found", ok: true,
                    detail: "The brief is well formed and no cheap impossibility was found."
                      + (result.problem ? " Below: the brief as it will be solved." : "") });
    } else {
      showMessage({
        title: result.errors.length ? `${result.errors.length} invalid field(s)`
                                    : "No layout can exist",
        items: [...withHints(result.errors), ...result.findings.map((f) => ["", f])],
      });
    }
    showExpanded(result.problem);
  } catch (err) {
    showProblem(err);
  }
}

/** The brief the server sent back (a template filled in), kept on the page to edit. */
function showExpanded(problem) {
  state.expanded = problem ?? null;
  $("expanded").hidden = !problem;
  $("expanded-json").textContent = problem ? prettyJson(problem) : "";
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
  setupBrief(briefChanged);
  $("use-expanded").addEventListener("click", () => {
    if (state.expanded) loadBrief(structuredClone(state.expanded));
  });
  const box = $("problem");
  box.addEventListener("input", jsonEdited);
  box.addEventListener("dragover", (e) => { e.preventDefault(); box.classList.add("dragging"); });
  box.addEventListener("dragleave", () => box.classList.remove("dragging"));
  box.addEventListener("drop", (e) => {
    e.preventDefault();
    box.classList.remove("dragging");
    readFile(e.dataTransfer.files[0]);
  });
  $("problem-form").addEventListener("submit", submit);
  $("validate").addEventListener("click", validate);
  $("save-brief").addEventListener("click", () => {
    try {
      const name = saveBrief(JSON.parse($("problem").value));
      listSaved($("example"));
      showMessage({ title: `Saved as "${name}"`, ok: true,
                    detail: "Open it again from Start from, in this browser." });
    } catch (err) {
      showProblem(err);
    }
  });
  $("cancel").addEventListener("click", cancel);
  $("downloads").addEventListener("click", downloadFile);
  setInterval(showElapsed, CLOCK_MS);
  setupExplore({ resubmit, show: showView,
                 briefText: (problem) => (problem ? prettyJson(problem) : $("problem").value) });

  loadExamples();
  probeKey();
  const saved = sessionStorage.getItem(JOB_STORAGE);
  if (saved) {
    const job = JSON.parse(saved);
    loadBrief(job.problem);
    follow(job); // replays its events from the start, or shows how it ended
  }
}

start();
