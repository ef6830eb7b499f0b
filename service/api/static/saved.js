// Briefs saved in this browser (localStorage), by name, to open again after a reload.

const STORAGE = "floorplan.briefs";
const PREFIX = "saved:";

function all() {
  try {
    return JSON.parse(localStorage.getItem(STORAGE) ?? "{}") ?? {};
  } catch {
    return {}; // unreadable: start afresh rather than fail the page
  }
}

/** Keeps `brief` under its name (or "brief"); returns the name used. */
export function saveBrief(brief) {
  const name = String(brief?.name || "brief");
  const briefs = all();
  briefs[name] = brief;
  localStorage.setItem(STORAGE, JSON.stringify(briefs));
  return name;
}

/** The saved briefs as options of the "Start from" list, in an optgroup of their own. */
export function listSaved(select) {
  select.querySelector("optgroup.saved")?.remove();
  const names = Object.keys(all()).sort();
  if (!names.length) return;
  const group = document.createElement("optgroup");
  group.className = "saved";
  group.label = "Saved in this browser";
  for (const name of names) group.append(new Option(name, PREFIX + name));
  select.append(group);
}

/** The brief of a "Start from" value, when it is a saved one (else undefined). */
export function savedBrief(value) {
  return value.startsWith(PREFIX) ? structuredClone(all()[value.slice(PREFIX.length)]) : undefined;
}
