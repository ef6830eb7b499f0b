// Calling the API from the page, and showing its problem documents (RFC 9457) with
// every refused field and what to write instead.

import { currentBrief, showFieldErrors } from "./brief.js";
import { hintFor } from "./words.js";

const $ = (id) => document.getElementById(id);

export class ApiProblem extends Error {
  /** An RFC 9457 problem document, or one made up for a failure without one. */
  constructor(doc) {
    super(doc.detail || doc.title);
    this.doc = doc;
  }
}

export function authHeaders() {
  const key = $("api-key").value.trim();
  return key ? { Authorization: `Bearer ${key}` } : {};
}

export async function problemOf(response) {
  const type = response.headers.get("content-type") || "";
  if (type.includes("json")) {
    try {
      return await response.json();
    } catch { /* not JSON after all: fall through */ }
  }
  return { title: response.statusText || "Error", status: response.status,
           detail: (await response.text().catch(() => "")).slice(0, 300) };
}

export async function api(path, { method = "GET", body } = {}) {
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

export function showMessage({ title, detail = "", items = [], ok = false }) {
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

export function clearMessage() {
  $("messages").hidden = true;
}

export function showProblem(err) {
  const doc = err instanceof ApiProblem ? err.doc : { title: "Error", detail: String(err) };
  const status = doc.status ? ` (${doc.status})` : "";
  const errors = doc.errors || [];
  if (errors.length) showFieldErrors(errors);
  showMessage({ title: `${doc.title}${status}`, detail: doc.detail, items: withHints(errors) });
  if (doc.status === 401) askForKey();
}

/** Refused fields as message items, each with what to write instead. */
export function withHints(errors) {
  const names = (currentBrief()?.rooms ?? []).map((r) => r?.id).filter(Boolean);
  return errors.map((e) => {
    const hint = hintFor(e, names);
    return [e.field, `${e.message}${hint ? ` — ${hint}` : ""}`];
  });
}

export function askForKey() {
  const note = $("key-note");
  note.textContent = "This server requires an API key.";
  note.classList.add("required");
  $("key-box").open = true;
  $("api-key").focus();
}
