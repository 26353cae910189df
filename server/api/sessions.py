"""Live simulated robots: create, drive (steer, maneuver, push, reset, play/pause/speed), read (state, plan), end.

Each session steps in real time in the background; reads return the latest published snapshot and never wait for
the physics. Writes and driving need the API token when the server is bound beyond loopback.
"""

from __future__ import annotations

from typing import Annotated, Any

from fastapi import APIRouter, Path, Response
from fastapi.concurrency import run_in_threadpool
from fastapi.responses import HTMLResponse, JSONResponse

from server.deps import ServicesDep, SessionsDep, WriteAccess
from server.errors import ApiError
from server.robots import default_name, resolve_robot
from server.schemas import (
    SessionControlIn,
    SessionCreate,
    SessionCreated,
    SessionManeuverIn,
    SessionPushIn,
    SessionResetIn,
    SteerIn,
)
from server.services import resolve_maneuver
from server.terrains import resolve_terrain

router = APIRouter(prefix="/sessions", tags=["sessions"])
SessionId = Annotated[str, Path(max_length=64, description="the id POST /sessions answered with")]


@router.post(
    "",
    status_code=201,
    response_model=SessionCreated,
    dependencies=[WriteAccess],
    summary="A live simulated robot on a terrain, standing, stepping in real time",
)
async def create_session(body: SessionCreate, sessions: SessionsDep, services: ServicesDep) -> JSONResponse:
    terrain = await run_in_threadpool(resolve_terrain, str(body.terrain), services.settings)
    robot = (
        None if body.robot is None else await run_in_threadpool(resolve_robot, body.robot, services.settings)
    )
    s = await run_in_threadpool(sessions.create, terrain, body.mode, "api", body.maps, robot)
    return JSONResponse(
        {
            "id": s.id,
            "terrain": s.terrain,
            "robot": body.robot or default_name(services.settings),
            "mode": s.mode,
            "maps": s.maps,
            "state_url": f"/sessions/{s.id}/state",
        },
        status_code=201,
        headers={"Location": f"/sessions/{s.id}"},
    )


@router.get("", summary="The live sessions")
def list_sessions(sessions: SessionsDep) -> list[dict[str, Any]]:
    return [s.summary() for s in sessions.list_sessions()]


@router.get("/{session_id}", summary="Same as /state")
@router.get("/{session_id}/state", summary="Pose, joints, contacts, status (crashes are reported here)")
async def session_state(session_id: SessionId, sessions: SessionsDep) -> Response:
    # async and pre-encoded: many clients poll this, and it must not slow the sessions stepping beside it
    return Response(sessions.get(session_id).state_json(), media_type="application/json")


@router.get(
    "/{session_id}/plan",
    summary="Overlays of what the controller plans now: step plan, capture point, contact forces, body path, ...",
)
def session_plan(session_id: SessionId, sessions: SessionsDep) -> dict[str, Any]:
    return sessions.get(session_id).plan()


@router.get("/{session_id}/report", summary="The run report (CONTRACT.md) of the current maneuver so far")
def session_report(session_id: SessionId, sessions: SessionsDep) -> dict[str, Any]:
    s = sessions.get(session_id)
    try:
        return s.report()
    except Exception as e:  # noqa: BLE001 - a report that cannot be built is a conflict with the session's state
        raise ApiError(409, f"no report for this session now: {type(e).__name__}: {e}"[:300],
                       [{"field": "id", "reason": "report unavailable"}]) from None  # fmt: skip


@router.get(
    "/{session_id}/recording",
    response_class=HTMLResponse,
    summary="The current maneuver's preview so far as a self-contained HTML page that plays without the server",
)
async def session_recording(session_id: SessionId, sessions: SessionsDep) -> HTMLResponse:
    from server.studio.recording import recording_html

    s = sessions.get(session_id)
    html, name = await run_in_threadpool(recording_html, s)
    return HTMLResponse(html, headers={"Content-Disposition": f'attachment; filename="{name}.html"'})


@router.post(
    "/{session_id}/steer",
    dependencies=[WriteAccess],
    summary="Velocity command (m/s, m/s, rad/s) and gait; a session running a maneuver switches to walking",
)
def session_steer(session_id: SessionId, body: SteerIn, sessions: SessionsDep) -> dict[str, Any]:
    s = sessions.get(session_id)
    s.steer(body.vx, body.vy, body.yaw_rate, body.gait, body.weights)
    return s.state()


@router.post(
    "/{session_id}/maneuver",
    dependencies=[WriteAccess],
    summary="Start a maneuver (library name or inline document, validated) from the stance at the origin",
)
async def session_maneuver(
    session_id: SessionId, body: SessionManeuverIn, services: ServicesDep, sessions: SessionsDep
) -> dict[str, Any]:
    s = sessions.get(session_id)
    maneuver = await run_in_threadpool(resolve_maneuver, body.maneuver, services)
    if body.speed is not None:
        await run_in_threadpool(s.set_speed, body.speed)
    await run_in_threadpool(s.start_maneuver, maneuver)
    return s.state()


@router.post(
    "/{session_id}/push", dependencies=[WriteAccess], summary="Push the body now (force N, duration s)"
)
def session_push(session_id: SessionId, body: SessionPushIn, sessions: SessionsDep) -> dict[str, Any]:
    s = sessions.get(session_id)
    s.push((body.force[0], body.force[1], body.force[2]), body.duration)
    return {"ok": True, "impulse_ns": round(sum(f * f for f in body.force) ** 0.5 * body.duration, 4)}


@router.post(
    "/{session_id}/reset",
    dependencies=[WriteAccess],
    summary="Back to standing at the origin, optionally on another terrain or robot (also clears a crash)",
)
async def session_reset(
    session_id: SessionId, sessions: SessionsDep, services: ServicesDep, body: SessionResetIn | None = None
) -> dict[str, Any]:
    s = sessions.get(session_id)
    terrain = None
    if body is not None and body.terrain is not None:
        terrain = await run_in_threadpool(resolve_terrain, str(body.terrain), services.settings)
    robot = None
    if body is not None and body.robot is not None:
        robot = await run_in_threadpool(resolve_robot, body.robot, services.settings)
    await run_in_threadpool(s.reset, terrain, body.maps if body is not None else None, robot)
    return s.state()


@router.post("/{session_id}/control", dependencies=[WriteAccess], summary="Play, pause, restart; speed")
async def session_control(
    session_id: SessionId, body: SessionControlIn, sessions: SessionsDep
) -> dict[str, Any]:
    s = sessions.get(session_id)

    def control() -> None:  # in the thread pool: a session in a worker process answers over its pipe
        if body.speed is not None:
            s.set_speed(body.speed)
        if body.action == "pause":
            s.pause()
        elif body.action == "play":
            s.resume()
        elif body.action == "restart":
            s.restart()

    await run_in_threadpool(control)
    return s.state()


@router.delete("/{session_id}", status_code=204, dependencies=[WriteAccess], summary="End a session")
def delete_session(session_id: SessionId, sessions: SessionsDep) -> Response:
    sessions.delete(session_id)
    return Response(status_code=204)
