// Server-Sent Events read with fetch rather than EventSource: EventSource cannot send
// an Authorization header, and servers with API keys need one on the event stream.
// The reader keeps the last event id and resumes with Last-Event-ID after a dropped
// connection, as EventSource would.

const RETRY_FIRST_MS = 500;
const RETRY_MAX_MS = 8000;

/** Parses a text/event-stream body, calling onEvent({id, type, data}) per event. */
export class EventStreamParser {
  constructor(onEvent) {
    this.onEvent = onEvent;
    this.buffer = "";
    this.lastEventId = null;
    this.type = "";
    this.data = [];
  }

  push(text) {
    this.buffer += text;
    // A line ends at \r\n, \n or \r; a lone \r at the end may be half of a \r\n.
    const lines = this.buffer.split(/\r\n|\n|\r(?!$)/);
    this.buffer = lines.pop();
    for (const line of lines) this.line(line);
  }

  line(line) {
    if (line === "") {
      if (this.data.length) {
        this.onEvent({ id: this.lastEventId, type: this.type || "message",
                       data: this.data.join("\n") });
      }
      this.type = "";
      this.data = [];
      return;
    }
    if (line.startsWith(":")) return; // a comment: the server's keep-alive
    const colon = line.indexOf(":");
    const field = colon < 0 ? line : line.slice(0, colon);
    let value = colon < 0 ? "" : line.slice(colon + 1);
    if (value.startsWith(" ")) value = value.slice(1);
    if (field === "event") this.type = value;
    else if (field === "data") this.data.push(value);
    else if (field === "id" && !value.includes("\0")) this.lastEventId = value;
  }
}

/**
 * Follows the event stream at `url` until `isFinished()` holds after a stream ends.
 * `headers()` gives the request headers (the API key); `onEvent` gets each event;
 * `onProblem(response)` is called for an error answer, which ends the following;
 * `onReconnect(delayMs)` tells that the connection dropped. Returns when done or
 * when `signal` aborts.
 */
export async function followEvents(url, { headers, onEvent, onProblem, onReconnect,
                                          isFinished, signal }) {
  const parser = new EventStreamParser(onEvent);
  let delay = RETRY_FIRST_MS;
  while (!signal.aborted) {
    try {
      const sent = { ...headers(), Accept: "text/event-stream" };
      if (parser.lastEventId) sent["Last-Event-ID"] = parser.lastEventId;
      const response = await fetch(url, { headers: sent, signal, cache: "no-store" });
      if (!response.ok) {
        await onProblem(response);
        return;
      }
      const reader = response.body.pipeThrough(new TextDecoderStream()).getReader();
      for (;;) {
        const { value, done } = await reader.read();
        if (done) break;
        parser.push(value);
        delay = RETRY_FIRST_MS; // data flows again: the next drop starts afresh
      }
      parser.push("\n"); // a last line without its newline still counts
    } catch (err) {
      if (signal.aborted) return;
      console.warn("event stream dropped:", err);
    }
    // The server ends the stream when the job ends; otherwise the connection broke.
    if (isFinished() || signal.aborted) return;
    onReconnect(delay);
    await new Promise((resolve) => setTimeout(resolve, delay));
    delay = Math.min(delay * 2, RETRY_MAX_MS);
  }
}
