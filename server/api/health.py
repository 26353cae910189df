"""Liveness and what the service offers: GET /health, GET /terrains, GET /schema/maneuver."""

from __future__ import annotations

from functools import lru_cache
from typing import Any

from fastapi import APIRouter

from server.deps import ServicesDep

router = APIRouter(tags=["service"])


@router.get("/health", summary="Liveness: {'status': 'ok'}")
def health(services: ServicesDep) -> dict[str, Any]:
    return {
        "status": "ok",
        "sessions": len(services.sessions),
        "studio": services.studio is not None,
        "token_required": services.settings.token_required,
    }


@router.get(
    "/terrains",
    summary="The terrain names, what each is, and the parameters a terrain field may override (with ranges)",
)
def terrains() -> list[dict[str, Any]]:
    return _terrains()


@lru_cache(maxsize=1)
def _terrains() -> list[dict[str, Any]]:
    from planning.terrain.scenes import TERRAIN_NAMES, build_terrain, param_info

    out = []
    for name in TERRAIN_NAMES:
        try:
            desc = str(build_terrain(name).description)
        except Exception:  # noqa: BLE001 - a description is a nicety; the name is what matters
            desc = ""
        params = [
            {"name": i.name, "kind": i.kind, "default": i.default, "range": i.range, "unit": i.unit}
            for i in param_info(name)
        ]
        out.append({"name": name, "description": desc, "params": params})
    return out


@router.get("/schema/maneuver", summary="The JSON Schema of a maneuver file (footfall/maneuver@1)")
def maneuver_schema() -> dict[str, Any]:
    from planning.maneuver import maneuver_json_schema

    return maneuver_json_schema()
