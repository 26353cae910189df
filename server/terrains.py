"""Terrains named over the network (REST and the studio): the same forms as ``--terrain``, except that a file is
one the user uploaded into ``<data dir>/terrains`` (PUT /terrain-files/{name}), named by its bare file name.

A client never names a server path: a file name with a directory part, a '..', or a name not uploaded is refused,
and an uploaded MJCF scene may only refer to files beside it. Resolution turns a terrain into the string the
simulation runs (the file's full path inside the terrain directory) after building it once, so a scene that
cannot be built is answered 422 before any simulation starts.
"""

from __future__ import annotations

import os
import re
import tempfile
from collections.abc import Mapping
from pathlib import Path
from typing import Any

from planning.terrain.spec import FILE_SUFFIXES, TerrainSpec, TerrainSpecError, as_spec, load_terrain
from planning.terrain.userscene import MAX_FILE_BYTES, UserTerrainError, check_file_references
from server.errors import ApiError, field_error
from server.settings import Settings

TERRAIN_SUBDIR = "terrains"
MAX_TERRAIN_FILES = 200  # files kept in the terrain directory
MAX_FILE_NAME = 83  # characters, whatever the extension (the OpenAPI description says so)
FILE_NAME_RE = re.compile(r"^[A-Za-z0-9][A-Za-z0-9_.-]{0,78}\.(xml|npy|png|yaml|stl|obj)$")
FILE_NAME_RULE = (
    "letters, digits, '_', '.', '-' (at most 80), ending in .xml, .npy, .png, .yaml, .stl or .obj"
)
_KIND = {".xml": "mjcf", ".npy": "heightmap", ".png": "heightmap", ".yaml": "heightmap options", ".stl": "mesh",
         ".obj": "mesh"}  # fmt: skip


def terrain_dir(settings: Settings) -> Path:
    """Gives the directory of uploaded terrain files."""
    return settings.data_dir / TERRAIN_SUBDIR


def check_file_name(name: str, field: str = "name") -> str:
    """Gives name if it is a bare terrain file name (no directory, no '..'); ApiError 422 naming `field` if not."""
    if len(name) > MAX_FILE_NAME or not FILE_NAME_RE.match(name) or ".." in name:
        raise field_error(422, field, f"{name[:100]!r} is not a terrain file name: {FILE_NAME_RULE}")
    return name


def parse_network_terrain(value: str | Mapping[str, Any]) -> TerrainSpec:
    """Gives the TerrainSpec of a terrain sent over the network; ValueError (for pydantic: 422 naming the field)
    when malformed or when it names a file by anything but a bare uploaded file name."""
    spec = as_spec(value)
    if spec.path is not None and (not FILE_NAME_RE.match(spec.path) or ".." in spec.path):
        raise TerrainSpecError(
            f"terrain file {spec.path[:100]!r}: over the network a file is one uploaded with "
            f"PUT /terrain-files/NAME, named by NAME ({FILE_NAME_RULE})"
        )
    return spec


def resolve_terrain(value: str | Mapping[str, Any], settings: Settings, field: str = "terrain") -> str:
    """Gives the terrain string a simulation runs (an uploaded file by its full path), after building the terrain
    once; ApiError 422 naming `field` when it is malformed, not uploaded or cannot be built."""
    try:
        spec = parse_network_terrain(value)
    except TerrainSpecError as e:
        raise field_error(422, field, str(e)) from None
    if spec.path is not None:
        root = terrain_dir(settings)
        path = root / spec.path
        if not path.is_file():
            raise field_error(
                422, field, f"no uploaded terrain file {spec.path!r} (PUT /terrain-files/{spec.path})"
            )
        spec = TerrainSpec(path=str(path), overrides=spec.overrides)
        try:
            if path.suffix.lower() == ".xml":
                check_file_references(path, root)
        except UserTerrainError as e:
            raise field_error(422, field, _hide(str(e), root)) from None
    text = spec.text()
    try:
        load_terrain(text)
    except TerrainSpecError as e:
        raise field_error(422, field, _hide(str(e), terrain_dir(settings))) from None
    return text


def _hide(message: str, root: Path) -> str:
    """Gives message without the server's terrain directory in it."""
    return message.replace(str(root.resolve()) + os.sep, "").replace(str(root) + os.sep, "")


def list_files(settings: Settings) -> list[dict[str, Any]]:
    """Gives the uploaded terrain files: name, bytes, kind."""
    root = terrain_dir(settings)
    if not root.is_dir():
        return []
    out = []
    for p in sorted(root.iterdir()):
        if p.is_file() and FILE_NAME_RE.match(p.name):
            out.append({"name": p.name, "bytes": p.stat().st_size, "kind": _KIND[p.suffix.lower()]})
    return out


def save_file(settings: Settings, name: str, data: bytes) -> dict[str, Any]:
    """Stores an uploaded terrain file (replacing one of the same name) and gives its listing entry; ApiError for a
    bad name, an empty or too large body, or a full directory."""
    check_file_name(name)
    if not data:
        raise field_error(422, "body", "empty: send the file's bytes as the request body")
    if len(data) > MAX_FILE_BYTES:
        raise field_error(413, "body", f"larger than {MAX_FILE_BYTES} bytes")
    root = terrain_dir(settings)
    root.mkdir(parents=True, exist_ok=True)
    target = root / name
    if not target.exists() and len(list_files(settings)) >= MAX_TERRAIN_FILES:
        raise ApiError(409, f"the terrain directory holds {MAX_TERRAIN_FILES} files; delete some first",
                       [{"field": "name", "reason": "too many terrain files"}])  # fmt: skip
    fd, tmp = tempfile.mkstemp(dir=root, prefix=".upload-")
    try:
        with os.fdopen(fd, "wb") as f:
            f.write(data)
        os.replace(tmp, target)
    finally:
        if os.path.exists(tmp):
            os.unlink(tmp)
    return {"name": name, "bytes": len(data), "kind": _KIND[target.suffix.lower()]}


def delete_file(settings: Settings, name: str) -> None:
    """Deletes an uploaded terrain file; ApiError 404 when there is none of that name."""
    check_file_name(name)
    path = terrain_dir(settings) / name
    if not path.is_file():
        raise field_error(404, "name", f"no uploaded terrain file {name!r}")
    path.unlink()


__all__ = [
    "FILE_NAME_RE", "FILE_SUFFIXES", "check_file_name", "delete_file", "list_files", "parse_network_terrain",
    "resolve_terrain", "save_file", "terrain_dir",
]  # fmt: skip
