"""The maneuver library: list, read, create or replace (validated), delete, validate.

Bodies are a maneuver document as JSON (`application/json`) or as YAML text (`application/yaml`, stored as sent so
comments survive). Replacing a maneuver needs `If-Match` with the ETag it was read with (409 when someone else
changed it since; 428 when the header is missing); `If-None-Match: *` creates only.
"""

from __future__ import annotations

import dataclasses
import json
from typing import Annotated, Any

from fastapi import APIRouter, Header, Query, Request, Response
from fastapi import Path as PathParam
from fastapi.concurrency import run_in_threadpool
from fastapi.responses import JSONResponse, PlainTextResponse
from pydantic import BaseModel, Field

from planning.maneuver import ManeuverError
from planning.maneuver.load import read_yaml
from planning.maneuver.spec import NAME_PATTERN
from server.deps import ServicesDep, StoreDep, WriteAccess
from server.errors import ApiError, field_error
from server.robots import default_name, resolve_robot
from server.services import (
    maneuver_text,
    read_maneuver_body,
    require_valid,
    robot_model,
    to_maneuver,
    validate_with_physics,
)
from server.storage import check_name, problems_to_fields

router = APIRouter(prefix="/maneuvers", tags=["maneuvers"])

MANEUVER_BODY = {
    "requestBody": {
        "required": True,
        "content": {
            "application/json": {"schema": {"$ref": "#/components/schemas/Maneuver"}},
            "application/yaml": {"schema": {"type": "string", "description": "a maneuver file's text"}},
        },
    }
}
YAML_TEXT = {"description": "the file's text: a maneuver document in YAML"}  # any YAML value to a client
ANY_DOCUMENT = {"type": "object", "description": "a maneuver document (see Maneuver); any mapping is checked"}
VALIDATE_BODY = {
    "requestBody": {
        "required": True,
        "content": {
            "application/json": {"schema": ANY_DOCUMENT},
            "application/yaml": {"schema": ANY_DOCUMENT},
        },
    }
}
# documented, checked by check_name (its message says what a name is; FastAPI's would quote the regex)
NameParam = Annotated[
    str,
    PathParam(
        description="a maneuver name: lowercase letters, digits and single dashes",
        json_schema_extra={"pattern": NAME_PATTERN, "maxLength": 64},
    ),
]


class ManeuverSummary(BaseModel):
    name: str
    title: str | None = None
    duration: float | None = None
    source: str
    editable: bool
    problems: list[dict[str, Any]] | None = None


class ManeuverSaved(BaseModel):
    name: str
    source: str
    etag: str
    created: bool
    warnings: list[dict[str, Any]]
    physics: dict[str, Any] | None = None  # the physics check (see ValidationAnswer)


class ValidationAnswer(BaseModel):
    ok: bool
    robot: str | None = Field(
        None, description="the robot the maneuver was checked for (?robot, or the server's)"
    )
    warnings: list[dict[str, Any]]
    failures: list[dict[str, Any]]
    physics: dict[str, Any] | None = Field(
        None,
        description="the physics check (the maneuver run headless in MuJoCo): ran, success, fell, failure_reason, "
        "the event responsible for a failure, and per event (t, leg, type, path) the margins measured in the phase "
        "it starts: peak_torque_use (share of the joint's limit), friction_use (share of the maneuver's friction), "
        "stability_margin_m (capture point to support polygon), timing_error_s and place_error_m of touchdowns, "
        "margin (1 unused .. 0 at a limit) and status (ok, warning, failure, not reached)",
    )


PhysicsParam = Annotated[
    bool | None,
    Query(
        description="run the physics check (the whole maneuver simulated headless, about 0.3-1 s of CPU per "
        "simulated second; it waits its turn with the queued simulations). Default: on, unless the server "
        "runs with FOOTFALL_VALIDATE_PHYSICS=0"
    ),
]


RobotParam = Annotated[
    str | None,
    Query(
        description="check for this robot (a name GET /robots lists; the maneuver scaled to it, its torque and "
        "reach, and the physics check run on it). Default: the server's robot",
        max_length=200,
    ),
]


@router.get(
    "", response_model=list[ManeuverSummary], summary="The library: shipped (read-only) and user maneuvers"
)
def list_maneuvers(store: StoreDep) -> list[dict[str, Any]]:
    return store.list()


@router.post(
    "/validate",
    response_model=ValidationAnswer,
    openapi_extra=VALIDATE_BODY,
    summary="Check a maneuver without simulating: warnings (fixable) and failures (blocking)",
)
async def validate_maneuver_body(
    request: Request, services: ServicesDep, physics: PhysicsParam = None, robot: RobotParam = None
) -> dict[str, Any]:
    raw = await request.body()
    content_type = request.headers.get("content-type")

    def work() -> dict[str, Any]:
        settings = services.settings
        load = None if robot is None else resolve_robot(robot, settings)  # 422 naming `robot` when not listed
        name = robot if robot is not None else default_name(settings)
        body = read_maneuver_body(raw, content_type)
        if not isinstance(body.data, dict):
            kind = "empty" if body.data is None else f"a {type(body.data).__name__}"
            raise field_error(422, "body", f"must be a mapping of fields (a maneuver document), got {kind}")
        try:
            maneuver = to_maneuver(body.data, body.lines, settings, robot_model(services, load))
        except ApiError as e:
            if e.status != 422:
                raise
            return {"ok": False, "robot": name, "warnings": [], "failures": e.errors}
        result = validate_with_physics(maneuver, services, body.lines, physics, load)
        return {
            "ok": bool(result.ok),
            "robot": name,
            "warnings": problems_to_fields(list(result.warnings)),
            "failures": problems_to_fields(list(result.failures)),
            "physics": result.physics,
        }

    return await run_in_threadpool(work)


def _wants_yaml(request: Request, fmt: str | None) -> bool:
    if fmt is not None:
        return fmt == "yaml"
    accept = request.headers.get("accept", "")
    return "yaml" in accept and "json" not in accept


@router.get(
    "/{name}",
    summary="One maneuver: the document as JSON, or the file's text with ?format=yaml (or Accept: application/yaml)",
    responses={
        304: {"description": "not modified (If-None-Match named the current ETag)"},
        200: {
            "content": {
                "application/json": {"schema": {"$ref": "#/components/schemas/Maneuver"}},
                "application/yaml": {"schema": YAML_TEXT},
            },
            "headers": {
                "ETag": {"schema": {"type": "string"}, "description": "send back in If-Match to replace"}
            },
        },
    },
)
def get_maneuver(
    name: NameParam,
    request: Request,
    store: StoreDep,
    format: Annotated[str | None, Query(pattern="^(json|yaml)$")] = None,
    download: bool = False,
    if_none_match: Annotated[str | None, Header(include_in_schema=False)] = None,
) -> Response:
    stored = store.get(check_name(name))
    headers = {"ETag": stored.etag, "X-Footfall-Source": stored.source, "Cache-Control": "no-cache"}
    if if_none_match is not None and stored.etag in [
        t.strip().removeprefix("W/") for t in if_none_match.split(",")
    ]:
        return Response(status_code=304, headers=headers)
    if _wants_yaml(request, format):
        if download:
            headers["Content-Disposition"] = f'attachment; filename="{stored.name}.yaml"'
        return PlainTextResponse(stored.text, media_type="application/yaml", headers=headers)
    try:
        data, _ = read_yaml(stored.text)
    except ManeuverError as e:
        raise ApiError(422, f"the stored file of {name!r} does not parse: {e.problems[0]}",
                       problems_to_fields(e.problems)) from None  # fmt: skip
    if not _json_safe(data):
        raise field_error(
            422, "format", f"the file of {name!r} holds values JSON cannot carry; use ?format=yaml"
        )
    return Response(
        json.dumps(data, default=str, allow_nan=False), media_type="application/json", headers=headers
    )


def _json_safe(data: Any) -> bool:
    try:
        json.dumps(data, default=str, allow_nan=False)
    except (ValueError, TypeError, RecursionError):
        return False
    return True


@router.put(
    "/{name}",
    openapi_extra=MANEUVER_BODY,
    response_model=ManeuverSaved,
    dependencies=[WriteAccess],
    responses={
        201: {"description": "created"},
        409: {"description": "changed since read (If-Match)"},
        428: {"description": "If-Match required to replace"},
    },  # fmt: skip
    summary="Create or replace a user maneuver (validated; shipped maneuvers are read-only)",
)
async def put_maneuver(
    name: NameParam,
    request: Request,
    services: ServicesDep,
    if_match: Annotated[str | None, Header(max_length=500)] = None,
    if_none_match: Annotated[str | None, Header(max_length=500)] = None,
    physics: PhysicsParam = None,
) -> JSONResponse:
    check_name(name)
    raw = await request.body()
    content_type = request.headers.get("content-type")

    def work() -> JSONResponse:
        services.store._check_writable(name)  # 403 before the work of validating
        body = read_maneuver_body(raw, content_type)
        if isinstance(body.data, dict) and "name" not in body.data:
            body = dataclasses.replace(body, data={**body.data, "name": name}, is_yaml=False)
        maneuver = to_maneuver(body.data, body.lines, services.settings, services.robot)
        if maneuver.name != name:
            raise field_error(422, "name", f"must match the URL ({name!r}), got {maneuver.name!r}")
        result = require_valid(maneuver, services, body.lines, physics)
        stored, created = services.store.save(
            name, maneuver_text(body, maneuver), if_match=if_match, if_none_match=if_none_match
        )
        answer = {
            "name": stored.name,
            "source": stored.source,
            "etag": stored.etag,
            "created": created,
            "warnings": problems_to_fields(list(result.warnings)),
            "physics": result.physics,
        }
        return JSONResponse(
            answer, status_code=201 if created else 200,
            headers={"ETag": stored.etag, "Location": f"/maneuvers/{stored.name}"},
        )  # fmt: skip

    return await run_in_threadpool(work)


@router.delete(
    "/{name}",
    status_code=204,
    dependencies=[WriteAccess],
    summary="Delete a user maneuver (If-Match optional; shipped maneuvers are read-only)",
)
def delete_maneuver(
    name: NameParam,
    store: StoreDep,
    if_match: Annotated[str | None, Header(max_length=500)] = None,
) -> Response:
    store.delete(check_name(name), if_match=if_match)
    return Response(status_code=204)
