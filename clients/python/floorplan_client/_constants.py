"""Every number and name the client runs on, in one place."""

from __future__ import annotations

import httpx2 as httpx

#: Where the service listens when neither the caller nor ``$FLOORPLAN_URL`` says.
DEFAULT_BASE_URL = "http://127.0.0.1:8000"
#: Environment variables read when the caller gives no URL or no API key.
BASE_URL_ENV = "FLOORPLAN_URL"
API_KEY_ENV = "FLOORPLAN_API_KEY"

#: Each HTTP request: 5 s to connect, 30 s for each read, write or pool wait. The
#: event stream sends a keep-alive at least every 15 s, so a read of 30 s never
#: times out on a quiet but healthy stream.
DEFAULT_TIMEOUT = httpx.Timeout(30.0, connect=5.0)

#: Retries after the first attempt, for connection failures and `RETRY_STATUSES`.
DEFAULT_MAX_RETRIES = 2
#: Answers worth another try: the request timed out, the queue is full, the service
#: (or a proxy in front of it) is failing or unavailable for now.
RETRY_STATUSES = frozenset({408, 429, 500, 502, 503, 504})
#: Backoff between retries: INITIAL_RETRY_DELAY * 2**n seconds, at most MAX_RETRY_DELAY,
#: times a random factor in [1 - RETRY_JITTER, 1].
INITIAL_RETRY_DELAY = 0.5
MAX_RETRY_DELAY = 8.0
RETRY_JITTER = 0.25
#: A `Retry-After` up to this many seconds is waited out; a longer one is not retried
#: (the error goes to the caller, with `retry_after` set).
MAX_RETRY_AFTER = 60.0

#: Polling (`Job.wait`, and `Job.events` where the event stream is unavailable): the
#: first pause, its growth while nothing changes, its cap, and its jitter.
POLL_INITIAL = 0.25
POLL_FACTOR = 1.5
POLL_MAX = 2.0
POLL_JITTER = 0.25

#: Statuses of the events endpoint that mean "no event stream here" (a server or proxy
#: without it): `Job.events` then polls instead.
NO_STREAM_STATUSES = frozenset({404, 405, 406, 501})

#: Prefix of the service's problem types (a relative reference into its docs); the
#: client uses it too for the documents it makes from a failed job's error.
PROBLEM_TYPES = "/docs/problems/"
#: Problem type of the service's 404 for a job without a layout yet.
NO_RESULT_YET = "no-result-yet"
#: Prefix of the service's problem types (a relative reference into its docs); the
#: client uses it too for the documents it makes from a failed job's error.
PROBLEM_TYPES = "/docs/problems/"
#: Problem type of the service's 404 for an unknown job (unlike a route it lacks).
JOB_NOT_FOUND = "job-not-found"

#: Jobs per page of `Client.list` unless told.
DEFAULT_PAGE_SIZE = 50
