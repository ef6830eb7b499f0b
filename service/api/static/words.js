// The solver's and the validator's words turned into an architect's: what the solve is
// doing now, what a refused field should say instead, and what to try after a failure.
// Text only: nothing here changes what is sent.

/** A size window's label (solver/pipeline/first_layout.py) in plain words. */
function windowWords(label) {
  const within = /target \+-(\d+)%/.exec(label);
  if (within) return `room sizes within ${within[1]} % of their targets`;
  if (label.startsWith("user bounds")) return "room sizes anywhere within your minimums and maximums";
  return `room sizes: ${label}`;
}

const FOUND = new Set(["optimal", "feasible", "timelimit", "gaplimit", "stalled", "interrupted"]);

function outcomeWords(status) {
  if (FOUND.has(status)) return "a layout fits";
  if (status === "infeasible" || status === "no_solution") return "none fits, widening the window";
  return status;
}

/** One progress event ({phase, detail, level, objective}) as a status line. */
export function phaseWords(p) {
  const detail = p.detail ?? "";
  let m;
  switch (p.phase) {
    case "relaxation":
      if ((m = /^size bounds (.+?)(?:, [^:]*)?: (\w+)$/.exec(detail))) {
        return `Trying ${windowWords(m[1])}: ${outcomeWords(m[2])}`;
      }
      if (/as two rectangles/.test(detail)) {
        return `Letting ${detail.split(" as ")[0]} be an L-shape to close a gap`;
      }
      if (/soft constraints priced/.test(detail)) return "Looking for the plan that breaks the fewest wishes";
      return detail ? `Trying again: ${detail}` : "Trying room sizes";
    case "level":
      if (/^level 1: one rectangle/.test(detail)) return "First layout: one rectangle per room";
      if ((m = /^level (\d+): (\d+) sub-domain/.exec(detail))) {
        return `Refining the plan (pass ${m[1]}, ${m[2]} part${m[2] === "1" ? "" : "s"})`;
      }
      if (/^SCIP's check/.test(detail)) return "Final check of the whole plan";
      if (/^edit:/.test(detail)) return "Laying out the rooms you left free around the kept ones";
      if (/another round/.test(detail)) return "Some floor is still uncovered: another round of refining";
      if (/neighbourhood search/.test(detail)) return "Trying small changes to the best plan";
      if (/reshaping/.test(detail)) return "Closing strips of floor between rooms";
      return detail ? `Improving the plan: ${detail}` : "Improving the plan";
    case "subdomain":
      if ((m = /^rooms (.+?): /.exec(detail))) return `Refined ${m[1]}`;
      return "Refining one part of the plan";
    case "incumbent":
      return "A better plan found";
    case "variant":
      return "Another design option found";
    case "conflict":
      return "Finding which requirements clash";
    case "done":
      return "Done";
    default:
      return detail;
  }
}

/** The job's status in words. */
export const STATUS_WORDS = {
  queued: "waiting to start", running: "laying out", succeeded: "done",
  failed: "no plan", canceled: "stopped", unknown: "unknown",
};

/** What `termination` means to the person waiting. */
export const TERMINATION_WORDS = {
  optimal: "the best plan this model allows (proved)",
  stalled: "stopped early: more time was unlikely to improve it",
  timelimit: "the time limit ended the search",
  interrupted: "stopped: the best plan found so far",
  infeasible: "no plan can meet every requirement",
  no_solution: "no plan found in the time given",
  in_progress: "still laying out",
};

const ROOM_FIELDS = "id, type, target_size, min_size, max_size, aspect_ratio, boundary, positions";

/** What to write instead, for one refused field ({field, message, type}); "" when the
 * message says it already. */
export function hintFor(error, roomNames = []) {
  const path = String(error.field ?? "").split(".");
  const last = path[path.length - 1];
  if (error.type === "extra_forbidden") {
    if (last === "area") {
      return 'a room has no "area": give "target_size": [width, depth] in metres '
        + "(in the form: type the area in Target m²)";
    }
    if (path[0] === "rooms") return `"${last}" is not a room field; a room takes ${ROOM_FIELDS}`;
    return `"${last}" is not a field here: remove it or check its spelling`;
  }
  if (error.type === "missing") {
    if (last === "boundary" && path.length === 1) {
      return "give the outline: width and depth in the form, or \"boundary\": [[0, 0], [10, 0], [10, 8], [0, 8]]";
    }
    if (last === "id") return "give the room a name";
    return `"${last}" is required here`;
  }
  if (/greater than/.test(error.message ?? "")) return "write a positive number of metres";
  if (/unknown room|not a room|no room/i.test(error.message ?? "") && roomNames.length) {
    return `name one of: ${roomNames.join(", ")}`;
  }
  if (/(list|tuple|array)/i.test(error.type ?? "") && /size/.test(path.join("."))) {
    return "write two lengths in metres, width and depth, like [3.5, 4]";
  }
  return "";
}

/** Rooms named by a conflict's constraints, by kind (sizes, walls, neighbours, ...). */
function conflictRooms(conflict) {
  const sizes = new Set();
  const others = new Set();
  for (const item of conflict?.constraints ?? []) {
    const bag = /size|aspect/.test(item.kind) ? sizes : others;
    for (const room of item.rooms ?? []) bag.add(room);
  }
  return { sizes: [...sizes], others: [...others] };
}

/** What to try when a solve ended without a valid plan: a list of sentences. */
export function whatToTry({ termination, conflict, timeLimit, findings = [] }) {
  const tips = [];
  const { sizes, others } = conflictRooms(conflict);
  if (sizes.length) {
    tips.push(`Relax the sizes of ${sizes.join(", ")} (lower their minimums or raise their maximums): `
      + "together they cannot fit.");
  }
  if (others.length) {
    tips.push(`Drop or loosen a wall or neighbour wish of ${others.join(", ")}.`);
  }
  if (termination === "no_solution" || termination === "timelimit" || termination === "interrupted") {
    const more = timeLimit ? ` (try ${Math.ceil(2 * timeLimit)} s)` : "";
    tips.push(`Give the solve more time${more}: no plan was proved impossible.`);
  }
  if (findings.length && !sizes.length) {
    tips.push("Make the outline larger or ask for fewer or smaller rooms: the rooms' minimum "
      + "sizes do not fit as they are.");
  }
  if (!tips.length) tips.push("Leave more sizes blank so that the template can fit them, or enlarge the outline.");
  return tips;
}
