"""Error answers: every 4xx body is ``{"detail": "<one line>", "errors": [{"field": ..., "reason": ...}, ...]}``.

Handlers turn request validation errors, library and session errors into that shape; a body-size middleware
answers 413 before a large body is read; an unexpected exception is logged and answered with a plain 500 (never a
traceback), which the tests treat as a bug.
"""

from __future__ import annotations

import logging
from collections.abc import Sequence
from typing import Any

from fastapi import FastAPI, Request
from fastapi.exceptions import RequestValidationError
from fastapi.responses import JSONResponse
from starlette.exceptions import HTTPException as StarletteHTTPException
from starlette.types import ASGIApp, Message, Receive, Scope, Send

from server.sessions import SessionError
from server.simulations import QueueFull
from server.storage import StorageError

log = logging.getLogger("footfall.api")


class ApiError(Exception):
    """An error answer with a status, a one-line detail and the fields it concerns."""

    def __init__(
        self,
        status: int,
        detail: str,
        errors: Sequence[dict[str, Any]] = (),
        headers: dict[str, str] | None = None,
    ) -> None:
        super().__init__(detail)
        self.status = status
        self.detail = detail
        self.errors = list(errors)
        self.headers = headers


def field_error(status: int, field: str, reason: str, **headers: str) -> ApiError:
    """Returns an ApiError about one field."""
    return ApiError(status, f"{field}: {reason}" if field else reason, [{"field": field, "reason": reason}],
                    headers or None)  # fmt: skip


def error_body(detail: str, errors: Sequence[dict[str, Any]] = ()) -> dict[str, Any]:
    return {"detail": detail, "errors": list(errors)}


def _loc_to_field(loc: Sequence[Any]) -> str:
    out = ""
    for item in loc:
        if isinstance(item, int):
            out += f"[{item}]"
        else:
            out += f".{item}" if out else str(item)
    return out


def _reason(err: dict[str, Any]) -> str:
    msg = str(err.get("msg", "is invalid"))
    for prefix in ("Value error, ", "Assertion failed, "):
        msg = msg.removeprefix(prefix)
    if err.get("type") == "missing":
        return "is required"
    if err.get("type") == "extra_forbidden":
        return "unknown field"
    if err.get("type") == "json_invalid":
        ctx = err.get("ctx") or {}
        return f"the body is not valid JSON ({ctx.get('error', 'syntax error')})"
    value = err.get("input")
    shown = repr(value)
    if len(shown) > 60:
        shown = shown[:57] + "..."
    if err.get("type") not in ("missing",) and value is not None and not isinstance(value, (dict, list)):
        return f"{msg[:1].lower() + msg[1:]} (got {shown})"
    return msg[:1].lower() + msg[1:]


def _allowed_methods(request: Request) -> list[str]:
    """Returns every method the API describes on the request's path (a path may have one route per method:
    Starlette's own 405 names only the first route's)."""
    import re

    app = request.app
    table = getattr(app.state, "allowed_methods", None)
    if table is None:
        table = [
            (
                re.compile("^" + re.sub(r"\\\{[^/]+?\\\}", "[^/]+", re.escape(path)) + "$"),
                sorted(m.upper() for m in ops),
            )
            for path, ops in app.openapi().get("paths", {}).items()
        ]
        app.state.allowed_methods = table
    path = request.url.path
    exact = app.openapi().get("paths", {}).get(path)  # /maneuvers/validate is itself, not /maneuvers/{name}
    if exact is not None:
        return sorted(m.upper() for m in exact)
    return sorted({m for pattern, methods in table if pattern.match(path) for m in methods})


def install(app: FastAPI) -> None:
    """Registers the error handlers on the app."""

    @app.exception_handler(ApiError)
    async def _api_error(request: Request, e: ApiError) -> JSONResponse:
        return JSONResponse(error_body(e.detail, e.errors), status_code=e.status, headers=e.headers)

    @app.exception_handler(RequestValidationError)
    async def _validation(request: Request, e: RequestValidationError) -> JSONResponse:
        errors = []
        for err in e.errors():
            loc = list(err.get("loc", ()))
            # drop pydantic's union branch names (e.g. "str", "PushIn") from the field path
            loc = [
                x
                for x in loc
                if not (isinstance(x, str) and (x[:1].isupper() or x in ("str", "dict[str,any]")))
            ]
            errors.append({"field": _loc_to_field(loc), "reason": _reason(err)})
        first = errors[0] if errors else {"field": "", "reason": "invalid request"}
        detail = f"{first['field']}: {first['reason']}" if first["field"] else first["reason"]
        return JSONResponse(error_body(detail, errors), status_code=422)

    @app.exception_handler(StorageError)
    async def _storage(request: Request, e: StorageError) -> JSONResponse:
        return JSONResponse(
            error_body(e.message, [{"field": e.field, "reason": e.message}]), status_code=e.status
        )

    @app.exception_handler(SessionError)
    async def _session(request: Request, e: SessionError) -> JSONResponse:
        return JSONResponse(
            error_body(e.message, [{"field": e.field, "reason": e.message}]), status_code=e.status
        )

    @app.exception_handler(QueueFull)
    async def _queue_full(request: Request, e: QueueFull) -> JSONResponse:
        return JSONResponse(
            error_body(str(e), [{"field": "simulations", "reason": str(e)}]), status_code=429,
            headers={"Retry-After": "10"},
        )  # fmt: skip

    @app.exception_handler(StarletteHTTPException)
    async def _http(request: Request, e: StarletteHTTPException) -> JSONResponse:
        detail = e.detail if isinstance(e.detail, str) else "error"
        if e.status_code == 404 and detail == "Not Found":
            detail = f"no such endpoint: {request.method} {request.url.path[:200]} (see /docs)"
        if e.status_code == 413:
            return JSONResponse(error_body(detail, [{"field": "body", "reason": detail}]), status_code=413,
                                headers={"Connection": "close"})  # fmt: skip
        field = ""
        headers = dict(getattr(e, "headers", None) or {})
        if e.status_code == 405:
            detail = f"{request.method} is not allowed on {request.url.path[:200]} (see /docs)"
            headers["Allow"] = ", ".join(_allowed_methods(request))
        elif e.status_code == 400 and detail == "There was an error parsing the body":
            field, detail = "body", "body: is not JSON text in UTF-8"
        return JSONResponse(
            error_body(detail, [{"field": field, "reason": detail.removeprefix(f"{field}: ")}]),
            status_code=e.status_code, headers=headers or None,
        )  # fmt: skip

    @app.exception_handler(Exception)
    async def _unexpected(request: Request, e: Exception) -> JSONResponse:
        log.exception("unexpected error on %s %s", request.method, request.url.path)
        return JSONResponse(
            error_body(f"internal error ({type(e).__name__}); this is a bug"), status_code=500
        )


class BodyTooLarge(StarletteHTTPException):
    """The request body grew past the limit while it was read (an HTTPException, so every route answers 413)."""

    def __init__(self, max_bytes: int) -> None:
        super().__init__(413, f"the request body is larger than {max_bytes} bytes")


class BodyLimit:
    """ASGI middleware: 413 for a body larger than `max_bytes`, by Content-Length before anything is read, or
    while a body without one (chunked) is streamed in."""

    def __init__(self, app: ASGIApp, max_bytes: int) -> None:
        self.app = app
        self.max_bytes = max_bytes

    async def _too_large(self, send: Send) -> None:
        import json

        body = json.dumps(
            error_body(
                f"the request body is larger than {self.max_bytes} bytes",
                [{"field": "body", "reason": f"larger than {self.max_bytes} bytes"}],
            )
        ).encode()
        await send({"type": "http.response.start", "status": 413,
                    "headers": [(b"content-type", b"application/json"), (b"content-length", str(len(body)).encode()),
                                (b"connection", b"close")]})  # fmt: skip
        await send({"type": "http.response.body", "body": body})

    async def __call__(self, scope: Scope, receive: Receive, send: Send) -> None:
        if scope["type"] != "http":
            await self.app(scope, receive, send)
            return
        for k, v in scope.get("headers", []):
            if k == b"content-length":
                try:
                    n = int(v)
                except ValueError:
                    n = -1
                if n < 0 or n > self.max_bytes:
                    await self._too_large(send)
                    return
        seen = 0

        async def limited_receive() -> Message:
            nonlocal seen
            msg = await receive()
            if msg["type"] == "http.request":
                seen += len(msg.get("body", b""))
                if seen > self.max_bytes:
                    raise BodyTooLarge(self.max_bytes)
            return msg

        await self.app(scope, limited_receive, send)


class HostCheck:
    """ASGI middleware: 421 for a request whose Host header is not one of `allowed` (port ignored).

    A server bound to loopback without a token trusts whoever can reach it; a web page from elsewhere reaches it
    through DNS rebinding (its own name resolved to 127.0.0.1), and then sends its own name as the Host. Checking
    the Host closes that door.
    """

    def __init__(self, app: ASGIApp, allowed: frozenset[str]) -> None:
        self.app = app
        self.allowed = frozenset(h.lower() for h in allowed)

    @staticmethod
    def host_name(value: str) -> str:
        """Returns the name of a Host header: without its port, IPv6 without brackets, lowercase."""
        v = value.strip().lower()
        if v.startswith("["):
            return v[1 : v.find("]")] if "]" in v else v
        return v.rsplit(":", 1)[0] if v.count(":") == 1 else v

    async def __call__(self, scope: Scope, receive: Receive, send: Send) -> None:
        if scope["type"] not in ("http", "websocket"):
            await self.app(scope, receive, send)
            return
        host = next((v.decode("latin-1") for k, v in scope.get("headers", []) if k == b"host"), "")
        if self.host_name(host) in self.allowed:
            await self.app(scope, receive, send)
            return
        if scope["type"] == "websocket":
            await send({"type": "websocket.close", "code": 1008})
            return
        import json

        detail = (
            f"Host {host[:100]!r} is not a name of this server; use one of {', '.join(sorted(self.allowed))}"
        )
        body = json.dumps(
            error_body(detail, [{"field": "Host", "reason": "not a name of this server"}])
        ).encode()
        await send({"type": "http.response.start", "status": 421,
                    "headers": [(b"content-type", b"application/json"), (b"content-length", str(len(body)).encode())]})  # fmt: skip
        await send({"type": "http.response.body", "body": body})
