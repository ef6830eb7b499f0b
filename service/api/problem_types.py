"""The problem types the service answers with: each `type` URI of a problem document
(``/docs/problems/KIND``) is a page served from here, saying what happened and what to
do. A route's `ApiError(kind=...)` names one of these (a test holds the code to it)."""

from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True)
class ProblemType:
    """One kind of problem: its status, its title and what the caller may do."""

    status: int
    title: str
    explanation: str


PROBLEM_TYPES: dict[str, ProblemType] = {
    "malformed-json": ProblemType(
        400, "Malformed JSON", "The body is not JSON: not UTF-8, cut short, nested deeper "
        "than the parser goes, or an integer of more than 4,300 digits. Send a JSON "
        "document."),
    "bad-cursor": ProblemType(
        400, "Bad cursor", "The `cursor` is not one this service gave out. Use the "
        "`next_cursor` of the previous page as it came."),
    "bad-last-event-id": ProblemType(
        400, "Bad Last-Event-ID", "The `Last-Event-ID` is past the last event of this "
        "job's stream. Resume with the id of an event the stream sent."),
    "untrusted-host": ProblemType(
        400, "Host not allowed", "The request's `Host` header names a host this service "
        "does not answer to (FLOORPLAN_ALLOWED_HOSTS), which keeps DNS rebinding out. Use "
        "one of the names it was set up with."),
    "unauthorized": ProblemType(
        401, "Unauthorized", "API keys are set and the request carried none that is "
        "valid. Send `Authorization: Bearer KEY` (or `X-API-Key: KEY`)."),
    "job-not-found": ProblemType(
        404, "Job not found", "No job of yours has this id: it never existed, was deleted "
        "or expired (FLOORPLAN_RETENTION_HOURS), or belongs to another API key."),
    "not-found": ProblemType(
        404, "Not found", "No batch of yours has this id: it never existed, or belongs to "
        "another API key."),
    "no-result-yet": ProblemType(
        404, "No layout yet", "The job has no layout yet (it is queued, or the solve has "
        "not found a first one), or for a design variant the job has not ended. Follow "
        "its events, or ask again later."),
    "no-such-variant": ProblemType(
        404, "No such variant", "The job found fewer design variants than the one asked "
        "for; `variants` of its layout lists those it found."),
    "example-not-found": ProblemType(
        404, "Example not found", "The service ships no example problem of that name; "
        "GET /v1/examples lists them."),
    "problem-type-not-found": ProblemType(
        404, "No such problem type", "This service answers with no problem of that type; "
        "/docs/problems lists those it does."),
    "idempotency-conflict": ProblemType(
        409, "Idempotency-Key reused", "This `Idempotency-Key` was sent before with "
        "another body. Use a new key for a new problem."),
    "job-not-finished": ProblemType(
        409, "Job not finished", "A queued or running job cannot be deleted. Cancel it "
        "first, then delete it."),
    "body-too-large": ProblemType(
        413, "Body too large", "The body exceeds FLOORPLAN_MAX_BODY_BYTES."),
    "problem-too-large": ProblemType(
        413, "Problem too large", "An outline, the obstacles or the regions have more "
        "items than this service takes (FLOORPLAN_MAX_VERTICES, FLOORPLAN_MAX_OBSTACLES, "
        "FLOORPLAN_MAX_REGIONS); `errors` names each list."),
    "batch-too-large": ProblemType(
        413, "Batch too large", "The batch's brief, stored once for all its "
        "layouts, takes more than FLOORPLAN_MAX_BATCH_BYTES. Send a smaller brief."),
    "unsupported-media-type": ProblemType(
        415, "Unsupported media type", "The body must be sent as `application/json`."),
    "invalid-problem": ProblemType(
        422, "Invalid problem", "The problem breaks the contract (docs/problem.md); "
        "`errors` names each field as a dotted path, with what is wrong with it."),
    "invalid-request": ProblemType(
        422, "Invalid request", "A parameter, header or body field is not what the "
        "operation takes; `errors` names each."),
    "queue-full": ProblemType(
        429, "Queue full", "The queue holds FLOORPLAN_QUEUE_LIMIT jobs. Try again after "
        "`Retry-After` seconds."),
    "too-many-jobs": ProblemType(
        429, "Too many jobs", "This key's queued and running jobs are at their limit "
        "(FLOORPLAN_MAX_JOBS_PER_KEY). Wait for some to end."),
    "too-many-streams": ProblemType(
        429, "Too many streams", "This key, or the whole service, has as many event "
        "streams open as it may (FLOORPLAN_MAX_STREAMS_PER_KEY, FLOORPLAN_MAX_STREAMS). "
        "Close one, or poll the job."),
    "too-many-explains": ProblemType(
        429, "Too many explanations", "This key's `explain=true` validations are at their "
        "limit (FLOORPLAN_MAX_EXPLAINS_PER_KEY). Wait for one to end."),
    "storage-quota": ProblemType(
        429, "Storage quota", "This key's jobs would keep more bytes in the store than "
        "FLOORPLAN_MAX_STORED_BYTES_PER_KEY (canceled jobs count until deleted). Delete "
        "finished jobs (DELETE /v1/layouts/{id}) to make room."),
    "explain-unavailable": ProblemType(
        503, "Explanation process lost", "The process explaining this validation was lost "
        "(killed, out of memory); it has been replaced. Try again after `Retry-After` "
        "seconds."),
    "export-unavailable": ProblemType(
        503, "Export process lost", "The process making this export was lost (killed, out "
        "of memory); it has been replaced. Try again after `Retry-After` seconds."),
    "store-unavailable": ProblemType(
        503, "Store unavailable", "The job store cannot take this request now: its disk "
        "is nearly full (FLOORPLAN_MIN_FREE_BYTES), it is read-only, or it is away. "
        "Nothing was taken; try again after `Retry-After` seconds."),
}
