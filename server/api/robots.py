"""The robots a session or a simulation may run: GET /robots (the shipped robots, the robot the server was started
on, and the robot files in ``<data dir>/robots``: ``NAME.xml`` or ``NAME/NAME.xml`` with its meshes). A session
names one with ``"robot": NAME`` (POST /sessions, POST /sessions/{id}/reset)."""

from __future__ import annotations

from typing import Any

from fastapi import APIRouter

from server import robots
from server.deps import ServicesDep

router = APIRouter(prefix="/robots", tags=["robots"])


@router.get(
    "",
    summary="The robots a session may run: name, source (shipped, server, file) and which one is the default",
)
def list_robots(services: ServicesDep) -> list[dict[str, Any]]:
    return robots.list_robots(services.settings)
