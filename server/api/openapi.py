"""The OpenAPI description's error answers: one error model, and every status each operation can answer.

FastAPI declares its own 422 shape (`detail` as a list) and nothing else; the service answers every error as
``{"detail": "<one line>", "errors": [{"field", "reason", ...}]}`` with the statuses listed here. What an operation
can answer follows from what it takes (parameters, a body, the write token, an id in its path) plus what its
resource adds (conflicts, preconditions, caps), so a new route gets its statuses without a list to forget.
"""

from __future__ import annotations

from typing import Any

from pydantic import BaseModel, ConfigDict, Field


class ErrorItem(BaseModel):
    """One thing wrong with a request; maneuver problems add their path, message, severity and YAML line."""

    model_config = ConfigDict(extra="allow")
    field: str = Field(description="what it is about: a body field path (events[3].t), a header, a parameter")
    reason: str = Field(description="why, in plain words")


class ErrorBody(BaseModel):
    """Every error answer (4xx, and the 500 of a bug)."""

    detail: str = Field(description="one line: the first problem, or a summary")
    errors: list[ErrorItem] = Field(description="every problem found, one per field")


WHY = {
    400: "the body is not text in UTF-8, or not parseable",
    401: "writes and driving need the API token (X-Footfall-Token or Authorization: Bearer)",
    403: "the token is wrong, or the resource is read-only (a shipped maneuver)",
    404: "no such resource",
    409: "conflicts with the resource's state (changed since read, already running, crashed, ...)",
    413: "the body is larger than FOOTFALL_MAX_BODY_BYTES",
    415: "the body's Content-Type is neither JSON nor YAML",
    421: "the Host header is not a name of this server (bound to loopback: DNS rebinding refused)",
    422: "the request or the maneuver in it is invalid: every problem, with its field (and YAML line)",
    428: "replacing needs If-Match with the ETag read",
    429: "a cap is reached (live sessions, queued simulations); Retry-After when it will pass",
}

# what a resource adds to what an operation's shape implies: (method, path) → statuses
EXTRA: dict[tuple[str, str], tuple[int, ...]] = {
    ("PUT", "/maneuvers/{name}"): (409, 428, 429),  # 429: the physics check finds the simulation queue full
    ("DELETE", "/maneuvers/{name}"): (409,),
    ("POST", "/maneuvers/validate"): (415, 429),
    ("POST", "/simulations"): (409, 429),
    ("DELETE", "/simulations/{job_id}"): (409,),
    ("POST", "/sessions"): (429,),
    ("POST", "/sessions/{session_id}/maneuver"): (409,),
    ("POST", "/sessions/{session_id}/steer"): (409,),
    ("POST", "/sessions/{session_id}/push"): (409,),
    ("POST", "/sessions/{session_id}/reset"): (409,),
    ("POST", "/sessions/{session_id}/control"): (409,),
    ("GET", "/sessions/{session_id}/report"): (409,),
    ("GET", "/sessions/{session_id}/recording"): (409,),
    ("POST", "/studio/preview"): (404, 409),  # 404: the maneuver to preview
}
MANEUVER_BODIES = {("PUT", "/maneuvers/{name}"), ("POST", "/maneuvers/validate")}


# operations that change nothing: open without the token (every other POST, PUT and DELETE needs it)
READS = {("POST", "/maneuvers/validate")}


def statuses_of(method: str, path: str, operation: dict[str, Any]) -> set[int]:
    """Returns the error statuses an operation can answer."""
    out = {421}
    takes_body = "requestBody" in operation
    if operation.get("parameters") or takes_body:
        out.add(422)
    if takes_body:
        out |= {400, 413, 422}
    if (method, path) in MANEUVER_BODIES:
        out.add(415)
    if method in ("POST", "PUT", "DELETE", "PATCH") and (method, path) not in READS:
        out |= {401, 403}
    if "{" in path:
        out.add(404)
    out |= set(EXTRA.get((method, path), ()))
    return out


def describe_errors(schema: dict[str, Any]) -> dict[str, Any]:
    """Returns the OpenAPI schema with ErrorBody as every error answer and every status each operation answers."""
    comps = schema.setdefault("components", {}).setdefault("schemas", {})
    comps["ErrorBody"] = ErrorBody.model_json_schema(ref_template="#/components/schemas/{model}")
    comps.update(comps["ErrorBody"].pop("$defs", {}))
    ref = {"$ref": "#/components/schemas/ErrorBody"}
    for path, item in schema.get("paths", {}).items():
        for method, op in item.items():
            if method.upper() not in ("GET", "POST", "PUT", "DELETE", "PATCH"):
                continue
            responses = op.setdefault("responses", {})
            for code in sorted(statuses_of(method.upper(), path, op)):
                old = responses.get(str(code), {})
                described = old.get("description") not in (None, "Validation Error")
                responses[str(code)] = {
                    "description": old["description"] if described else WHY[code],
                    "content": {"application/json": {"schema": ref}},
                    **({"headers": old["headers"]} if "headers" in old else {}),
                }
    for name in ("HTTPValidationError", "ValidationError"):
        comps.pop(name, None)
    return schema
