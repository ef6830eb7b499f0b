"""Every 4xx and 5xx as an RFC 9457 problem document (application/problem+json)."""

from __future__ import annotations

import logging
from collections.abc import Sequence
from http import HTTPStatus
from typing import Any

from fastapi import FastAPI, Request
from fastapi.exceptions import RequestValidationError
from fastapi.responses import JSONResponse
from pydantic import BaseModel, ValidationError
from sqlalchemy.exc import IntegrityError
from starlette.datastructures import Headers
from starlette.exceptions import HTTPException as StarletteHTTPException
from starlette.middleware.trustedhost import TrustedHostMiddleware
from starlette.types import ASGIApp, Message, Receive, Scope, Send

from floorplan.models.jobs import FieldError
from floorplan.service.store import StoreUnavailable

log = logging.getLogger("floorplan.api")

PROBLEM_JSON = "application/problem+json"
#: Problem type URIs are relative references into the docs; "about:blank" means the
#: HTTP status says it all (RFC 9457 §4.2.1).
TYPE_BASE = "/docs/problems/"
#: Retry-After (seconds) when the store cannot write.
STORE_RETRY_AFTER = 30


class ProblemDetails(BaseModel):
    """RFC 9457 problem details."""

    type: str = "about:blank"
    title: str
    status: int
    detail: str = ""
    instance: str | None = None
    errors: list[FieldError] | None = None


class ApiError(Exception):
    """Raised by routes and dependencies; rendered as a problem document."""

    def __init__(
        self, status: int, detail: str, *, kind: str | None = None, title: str | None = None,
        headers: dict[str, str] | None = None, errors: list[FieldError] | None = None,
    ) -> None:
        super().__init__(detail)
        self.status = status
        self.detail = detail
        self.kind = kind
        self.title = title or HTTPStatus(status).phrase
        self.headers = headers or {}
        self.errors = errors


def field_errors(errors: Sequence[Any], *, strip: int = 0) -> list[FieldError]:
    """Pydantic's errors as FieldErrors; `strip` drops leading loc parts ("body")."""
    out = []
    for e in errors:
        loc = [part for part in e["loc"][strip:]]
        out.append(FieldError(field=".".join(str(p) for p in loc) or "(body)", loc=loc,
                              message=e["msg"], type=e["type"]))
    return out


def problem_response(
    request: Request, status: int, detail: str, *, kind: str | None = None,
    title: str | None = None, headers: dict[str, str] | None = None,
    errors: list[FieldError] | None = None,
) -> JSONResponse:
    body = ProblemDetails(
        type=f"{TYPE_BASE}{kind}" if kind else "about:blank",
        title=title or HTTPStatus(status).phrase, status=status, detail=detail,
        instance=request.url.path, errors=errors,
    )
    return JSONResponse(body.model_dump(exclude_none=True), status_code=status,
                        headers=headers, media_type=PROBLEM_JSON)


class TrustedHosts:
    """Starlette's TrustedHostMiddleware (FLOORPLAN_ALLOWED_HOSTS), its refusal of a
    Host header not allowed answered with a problem document (400 untrusted-host)."""

    def __init__(self, app: ASGIApp, allowed_hosts: Sequence[str]) -> None:
        self.app = app
        self.check = TrustedHostMiddleware(self._trusted, allowed_hosts=allowed_hosts,
                                           www_redirect=False)

    async def _trusted(self, scope: Scope, receive: Receive, send: Send) -> None:
        scope[_TRUSTED] = True
        await self.app(scope, receive, send)

    async def __call__(self, scope: Scope, receive: Receive, send: Send) -> None:
        async def passed_or_refused(message: Message) -> None:
            if scope.get(_TRUSTED):
                await send(message)
            elif message["type"] == "http.response.start":  # the middleware's refusal
                host = Headers(scope=scope).get("host", "")[:100]
                await problem_response(
                    Request(scope), 400, f"this service does not answer to host {host!r} "
                    "(FLOORPLAN_ALLOWED_HOSTS)", kind="untrusted-host",
                )(scope, receive, send)

        await self.check(scope, receive, passed_or_refused)


#: The key in a request's scope that says its Host header was allowed.
_TRUSTED = "floorplan.trusted_host"


def install(app: FastAPI) -> None:
    """Route every error through `problem_response`."""

    @app.exception_handler(ApiError)
    async def api_error(request: Request, err: ApiError) -> JSONResponse:
        return problem_response(request, err.status, err.detail, kind=err.kind, title=err.title,
                                headers=err.headers, errors=err.errors)

    @app.exception_handler(RequestValidationError)
    async def request_invalid(request: Request, err: RequestValidationError) -> JSONResponse:
        errors = field_errors(err.errors())
        return problem_response(request, 422, f"{len(errors)} invalid field(s)",
                                kind="invalid-request", errors=errors)

    @app.exception_handler(ValidationError)
    async def model_invalid(request: Request, err: ValidationError) -> JSONResponse:
        errors = field_errors(err.errors())
        return problem_response(request, 422, f"{len(errors)} invalid field(s)",
                                kind="invalid-problem", errors=errors)

    @app.exception_handler(StarletteHTTPException)
    async def http_error(request: Request, err: StarletteHTTPException) -> JSONResponse:
        detail = err.detail if isinstance(err.detail, str) else HTTPStatus(err.status_code).phrase
        return problem_response(request, err.status_code, detail,
                                headers=getattr(err, "headers", None))

    @app.exception_handler(StoreUnavailable)
    async def store_unavailable(request: Request, err: StoreUnavailable) -> JSONResponse:
        if isinstance(err, IntegrityError):  # a bug, not the store's state
            return await unexpected(request, err)
        log.warning("the store refused %s %s: %s", request.method, request.url.path,
                    str(err.orig)[:300])
        return problem_response(request, 503, "the job store cannot take this request now "
                                "(it is full, read-only or away); try again later",
                                kind="store-unavailable",
                                headers={"Retry-After": str(STORE_RETRY_AFTER)})

    @app.exception_handler(Exception)
    async def unexpected(request: Request, err: Exception) -> JSONResponse:
        log.exception("unhandled error on %s", request.url.path)
        return problem_response(request, 500, "an internal error occurred; it has been logged")
