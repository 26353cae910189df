"""Terrain files the user brings: GET /terrain-files, PUT /terrain-files/{name} (the file's bytes as the body),
DELETE /terrain-files/{name}. A terrain field then names one by its file name: ``"room.xml"``,
``"hills.npy:cell_m=0.05"`` or ``{"file": "hills.npy", "params": {"cell_m": 0.05}}``."""

from __future__ import annotations

from typing import Annotated, Any

from fastapi import APIRouter, Path, Request, Response
from fastapi.concurrency import run_in_threadpool
from fastapi.responses import JSONResponse

from server import terrains
from server.deps import ServicesDep, WriteAccess

router = APIRouter(prefix="/terrain-files", tags=["terrains"])
# the rule of terrains.check_file_name as a JSON Schema pattern (no '..': dot-separated parts), so the description
# and the check agree (the OpenAPI fuzz test holds them to it); the check's message names the field `name`
FileName = Annotated[
    str,
    Path(
        description=f"the terrain file's name: {terrains.FILE_NAME_RULE}",
        json_schema_extra={
            "pattern": r"^[A-Za-z0-9][A-Za-z0-9_-]*(\.[A-Za-z0-9_-]+)*\.(xml|npy|png|yaml|stl|obj)$",
            "maxLength": terrains.MAX_FILE_NAME,
        },
    ),  # fmt: skip
]


@router.get("", summary="The uploaded terrain files (MJCF scenes, heightmaps and their YAML options)")
def list_terrain_files(services: ServicesDep) -> list[dict[str, Any]]:
    return terrains.list_files(services.settings)


@router.put(
    "/{name}",
    dependencies=[WriteAccess],
    responses={201: {"description": "uploaded (200: replaced)"}},
    summary="Upload a terrain file: an MJCF scene (.xml) and its meshes (.stl, .obj), a heightmap (.npy, .png) "
    "or a heightmap's options (.yaml, same name); the body is the file's bytes",
    openapi_extra={"requestBody": {"content": {"application/octet-stream": {"schema": {"type": "string",
                                                                                     "format": "binary"}}}}},
)  # fmt: skip
async def put_terrain_file(name: FileName, request: Request, services: ServicesDep) -> JSONResponse:
    terrains.check_file_name(name)
    data = await request.body()
    existed = (terrains.terrain_dir(services.settings) / name).is_file()
    entry = await run_in_threadpool(terrains.save_file, services.settings, name, data)
    return JSONResponse(entry, status_code=200 if existed else 201)


@router.delete(
    "/{name}", status_code=204, dependencies=[WriteAccess], summary="Delete an uploaded terrain file"
)
def delete_terrain_file(name: FileName, services: ServicesDep) -> Response:
    terrains.delete_file(services.settings, name)
    return Response(status_code=204)
