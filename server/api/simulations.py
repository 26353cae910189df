"""Queued headless runs: POST /simulations (202 + id), GET /simulations/{id} (status, progress, run report)."""

from __future__ import annotations

from typing import Annotated, Any

from fastapi import APIRouter, Path
from fastapi.concurrency import run_in_threadpool
from fastapi.responses import JSONResponse

from planning.sim.world import PushSpecError, parse_push
from server.deps import ServicesDep, SimulationsDep, WriteAccess
from server.errors import ApiError, field_error
from server.robots import default_name, resolve_robot
from server.schemas import PushIn, SimulationAccepted, SimulationCreate, SimulationPublic
from server.services import resolve_maneuver
from server.terrains import resolve_terrain

router = APIRouter(prefix="/simulations", tags=["simulations"])
JobId = Annotated[str, Path(max_length=64, description="the id POST /simulations answered with")]


def walk_runner() -> Any:
    """Returns the headless walk runner of the planning stack, or None in a build without steering."""
    try:
        from planning.sim import run as sim_run
    except ImportError:
        return None
    return getattr(sim_run, "run_walk", None)


def _terrain_speed_problem(terrain: str, speed: float) -> str | None:
    """Gives why a walk's terrain_speed (m/s) cannot be walked on this terrain (a resolved terrain string)."""
    from planning.sim.run import check_terrain_speed
    from planning.terrain.spec import load_terrain

    name = str(load_terrain(terrain).name)
    if name == "flat":
        return "only on a terrain (on flat ground vx and the gait's limits set the speed)"
    return check_terrain_speed(speed, name)


def _pushes(items: list[PushIn | str]) -> list[tuple[float, tuple[float, float, float], float]]:
    out = []
    for i, p in enumerate(items):
        if isinstance(p, str):
            try:
                q = parse_push(p)
            except PushSpecError as e:
                raise field_error(422, f"pushes[{i}]", str(e).removeprefix("--push ")) from None
            out.append((q.t_s, q.force_n, q.duration_s))
        else:
            out.append((p.t, (p.force[0], p.force[1], p.force[2]), p.duration))
    return out


@router.post(
    "",
    status_code=202,
    response_model=SimulationAccepted,
    dependencies=[WriteAccess],
    summary="Queue a headless run of a maneuver (library name or inline) or a walk; answers 202 with an id",
)
async def create_simulation(
    body: SimulationCreate, services: ServicesDep, pool: SimulationsDep
) -> JSONResponse:
    pushes = _pushes(body.pushes)
    terrain = await run_in_threadpool(resolve_terrain, str(body.terrain), services.settings)
    robot = (
        None if body.robot is None else await run_in_threadpool(resolve_robot, body.robot, services.settings)
    )
    common = {
        "terrain": terrain,
        "pushes": pushes,
        "duration": body.duration,
        "robot": robot or services.settings.robot,
    }
    request: dict[str, Any] = {
        "terrain": body.terrain,
        "robot": body.robot or default_name(services.settings),
        "pushes": [{"t": t, "force": list(f), "duration": d} for t, f, d in pushes],
        "duration": body.duration,
    }
    if body.walk is not None:
        if walk_runner() is None:
            raise field_error(409, "walk", "steering not available in this build; run a maneuver instead")
        if body.walk.terrain_speed is not None:
            why = await run_in_threadpool(_terrain_speed_problem, terrain, body.walk.terrain_speed)
            if why is not None:
                raise field_error(422, "body.walk.terrain_speed", why)
        walk = body.walk.model_dump()
        payload: dict[str, Any] = {"walk": walk, **common}
        request.update({"maneuver": None, "walk": walk})
    else:
        assert body.maneuver is not None
        maneuver = await run_in_threadpool(resolve_maneuver, body.maneuver, services)
        payload = {"maneuver": maneuver.model_dump(by_alias=True, mode="json"), **common}
        request.update({"maneuver": maneuver.name, "inline": not isinstance(body.maneuver, str)})
    job = pool.submit(request, payload)
    return JSONResponse(
        {"id": job.id, "status": job.status, "url": f"/simulations/{job.id}"},
        status_code=202,
        headers={"Location": f"/simulations/{job.id}"},
    )


@router.get("", summary="Recent simulations (without their reports)")
def list_simulations(pool: SimulationsDep) -> list[dict[str, Any]]:
    return [{k: v for k, v in j.public().items() if k != "report"} for j in pool.list()]


@router.get(
    "/{job_id}", response_model=SimulationPublic, summary="Status, progress and (once done) the run report"
)
def get_simulation(job_id: JobId, pool: SimulationsDep) -> dict[str, Any]:
    found = pool.get(job_id)
    if found is None:
        raise ApiError(404, f"no simulation {job_id[:40]!r}", [{"field": "id", "reason": "unknown"}])
    job, pos = found
    return job.public(pos)


@router.delete(
    "/{job_id}",
    response_model=SimulationPublic,
    dependencies=[WriteAccess],
    responses={409: {"description": "already running or finished: too late to cancel"}},
    summary="Cancel a queued simulation (it never runs); a running or finished one answers 409",
)
def cancel_simulation(job_id: JobId, pool: SimulationsDep) -> dict[str, Any]:
    job = pool.cancel(job_id)
    if job is None:
        raise ApiError(404, f"no simulation {job_id[:40]!r}", [{"field": "id", "reason": "unknown"}])
    if job.status != "cancelled":
        raise ApiError(409, f"simulation {job.id} is {job.status}; only a queued one can be cancelled",
                       [{"field": "id", "reason": f"already {job.status}"}])  # fmt: skip
    return job.public()
