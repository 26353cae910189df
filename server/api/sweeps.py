"""Robustness sweeps over REST: POST /sweeps (a footfall/sweep@1 spec; 202 + id), GET /sweeps/{id} (progress and
the summary so far), GET /sweeps/{id}/cases[/{key}], GET /sweeps/{id}/heatmap.png, POST /sweeps/{id}/cancel.
Same token rule and queue limit as simulations."""

from __future__ import annotations

from typing import Annotated, Any

from fastapi import APIRouter, Body, Depends, Path
from fastapi.concurrency import run_in_threadpool
from fastapi.responses import JSONResponse, Response

from server.deps import ServicesDep, WriteAccess
from server.errors import ApiError, error_body
from server.sweeps import SweepJob, SweepManager, SweepQueueFull, SweepRejected, manager_of

router = APIRouter(prefix="/sweeps", tags=["sweeps"])
SweepId = Annotated[str, Path(max_length=64, description="the id POST /sweeps answered with")]
CaseKey = Annotated[str, Path(max_length=64, description="a case's key (GET /sweeps/{id}/cases)")]


async def get_sweeps(services: ServicesDep) -> SweepManager:
    """The app's sweep manager, made on first use (and shut down with the app's services)."""
    return manager_of(services)


SweepsDep = Annotated[SweepManager, Depends(get_sweeps)]


def _job(manager: SweepManager, sweep_id: str) -> tuple[SweepJob, int | None]:
    found = manager.get(sweep_id)
    if found is None:
        raise ApiError(404, f"no sweep {sweep_id[:40]!r}", [{"field": "id", "reason": "unknown"}])
    return found


@router.post(
    "",
    status_code=202,
    dependencies=[WriteAccess],
    summary="Queue a robustness sweep (a footfall/sweep@1 spec as JSON); answers 202 with an id",
)
async def create_sweep(
    manager: SweepsDep,
    spec: Annotated[
        dict[str, Any], Body(description="the sweep spec (footfall/sweep@1), as in sweeps/*.yaml")
    ],
) -> JSONResponse:
    try:
        parsed, cases = await run_in_threadpool(manager.prepare, spec)
        job = manager.submit(parsed, cases)
    except SweepRejected as e:
        errors = [{"field": f, "reason": r} for f, r in e.problems]
        return JSONResponse(error_body(str(e)[:2000], errors), status_code=422)
    except SweepQueueFull as e:
        return JSONResponse(error_body(str(e), [{"field": "sweeps", "reason": str(e)}]), status_code=429,
                            headers={"Retry-After": "10"})  # fmt: skip
    return JSONResponse(
        {
            "id": job.id,
            "status": job.status,
            "url": f"/sweeps/{job.id}",
            "cases": len(cases),
            "runs": job.runs,
        },
        status_code=202,
        headers={"Location": f"/sweeps/{job.id}"},
    )


@router.get("", summary="Recent sweeps (status and progress)")
def list_sweeps(manager: SweepsDep) -> list[dict[str, Any]]:
    return [j.public() for j in manager.list()]


@router.get("/{sweep_id}", summary="Status, progress (done, rate, ETA, success rate) and the summary so far")
def get_sweep(sweep_id: SweepId, manager: SweepsDep) -> dict[str, Any]:
    job, pos = _job(manager, sweep_id)
    return job.public(pos, with_summary=True)


@router.get("/{sweep_id}/cases", summary="Every case: its axes, key, status, success and failure reason")
def list_cases(sweep_id: SweepId, manager: SweepsDep) -> list[dict[str, Any]]:
    job, _ = _job(manager, sweep_id)
    out = []
    for c in job.cases:
        r = job.records.get(c["key"])
        rep = (r or {}).get("report") or {}
        out.append({"key": c["key"], "axes": c["axes"], "status": r["status"] if r else "pending",
                    "success": rep.get("success"), "failure_reason": rep.get("failure_reason") or (r or {}).get("error")})  # fmt: skip
    return out


@router.get("/{sweep_id}/cases/{key}", summary="One case's stored record, with its full run report")
def get_case(sweep_id: SweepId, key: CaseKey, manager: SweepsDep) -> dict[str, Any]:
    job, _ = _job(manager, sweep_id)
    rec = manager.record(job, key)
    if rec is None:
        raise ApiError(
            404, f"no finished case {key[:40]!r} in this sweep", [{"field": "key", "reason": "unknown"}]
        )
    return rec


@router.get(
    "/{sweep_id}/heatmap.png",
    summary="The success heat map over two axes (PNG)",
    responses={200: {"content": {"image/png": {}}}},
    response_class=Response,
)
def get_heatmap(sweep_id: SweepId, manager: SweepsDep) -> Response:
    from planning.sweep.heatmap import png_bytes, render
    from planning.sweep.summary import summarize

    job, _ = _job(manager, sweep_id)
    hm = summarize(job.spec, job.cases, dict(job.records))["heatmap"]
    if hm is None:
        raise ApiError(404, "this sweep has fewer than two axes to draw (set summary.heatmap)",
                       [{"field": "summary.heatmap", "reason": "no two axes"}])  # fmt: skip
    return Response(png_bytes(render(hm, f"sweep {job.spec.name}: success")), media_type="image/png")


@router.post(
    "/{sweep_id}/cancel", dependencies=[WriteAccess], summary="Stop a sweep (finished cases are kept)"
)
def cancel_sweep(sweep_id: SweepId, manager: SweepsDep) -> dict[str, Any]:
    job = manager.cancel(sweep_id)
    if job is None:
        raise ApiError(404, f"no sweep {sweep_id[:40]!r}", [{"field": "id", "reason": "unknown"}])
    return job.public()
