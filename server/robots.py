"""Robots named over the network (REST and the studio's robot picker): the shipped robots, the robot the server was
started on (``--robot PATH.xml`` / ``FOOTFALL_ROBOT``) and the robot files in ``<data dir>/robots``.

A robot file is ``robots/NAME.xml`` or, for a model with its meshes, a folder ``robots/NAME/NAME.xml`` (its meshes
and an optional ``NAME.footfall.yaml`` beside it, as `footfall robot check` reads them); it is named NAME. A client
names a robot, never a server path: a name not listed is refused with the list. Resolution loads the robot once,
so a file that fails `footfall robot check` is answered 422 with its problems before any simulation starts.
"""

from __future__ import annotations

import os
import re
from pathlib import Path
from typing import Any

from server.errors import field_error
from server.settings import Settings

ROBOT_SUBDIR = "robots"
MAX_ROBOT_FILES = 100  # robot files listed from the robot directory (the rest are ignored, sorted by name)
ROBOT_NAME_RE = re.compile(r"^[A-Za-z0-9][A-Za-z0-9_-]{0,63}$")
ROBOT_NAME_RULE = "letters, digits, '_' and '-' (at most 64)"


def robot_dir(settings: Settings) -> Path:
    """Gives the directory of the robot files the server may load."""
    return settings.data_dir / ROBOT_SUBDIR


def _builtin() -> list[str]:
    from planning.robot import available_robots

    return available_robots()


def _server_robot(settings: Settings, taken: set[str]) -> tuple[str, str] | None:
    """Gives (name, path) of the robot the server was started on when it is a file (None for a shipped name): named
    by its file's stem, or ``server-STEM`` when a shipped robot has that name."""
    robot = settings.robot
    if robot in taken or Path(robot).suffix.lower() not in (".xml", ".yaml", ".yml"):
        return None
    stem = Path(robot).stem
    name = stem if stem not in taken and ROBOT_NAME_RE.match(stem) else f"server-{stem}"
    return name, str(Path(robot).resolve())


def _files(settings: Settings) -> list[tuple[str, Path]]:
    """Gives (name, path) of the robot files in the robot directory: NAME.xml, or NAME/NAME.xml."""
    root = robot_dir(settings)
    if not root.is_dir():
        return []
    out = []
    for p in sorted(root.iterdir()):
        if p.name.startswith(".") or not ROBOT_NAME_RE.match(p.stem if p.is_file() else p.name):
            continue
        if p.is_file() and p.suffix.lower() == ".xml":
            out.append((p.stem, p))
        elif p.is_dir() and (p / f"{p.name}.xml").is_file():
            out.append((p.name, p / f"{p.name}.xml"))
        if len(out) >= MAX_ROBOT_FILES:
            break
    return out


def _choices(settings: Settings) -> list[dict[str, Any]]:
    """Gives every robot a client may name: name, source ("shipped", "server", "file"), the string a simulation
    loads (``load``: a shipped name or a full path), and whether it is the server's default."""
    out: list[dict[str, Any]] = []
    for name in _builtin():
        out.append({"name": name, "source": "shipped", "load": name})
    taken = {e["name"] for e in out}
    server = _server_robot(settings, taken)
    if server is not None:
        out.append({"name": server[0], "source": "server", "load": server[1]})
        taken.add(server[0])
    for name, path in _files(settings):
        if name not in taken:  # a shipped or the server's robot keeps its name
            out.append({"name": name, "source": "file", "load": str(path)})
            taken.add(name)
    default = default_name(settings, out)
    for e in out:
        e["default"] = e["name"] == default
    return out


def default_name(settings: Settings, choices: list[dict[str, Any]] | None = None) -> str:
    """Gives the name of the robot sessions run when none is named (the server's robot)."""
    return name_of(settings.robot, settings, choices)


def name_of(load: str, settings: Settings, choices: list[dict[str, Any]] | None = None) -> str:
    """Gives the listed name of the robot a simulation loads from `load` (a shipped name or a path); its file's stem
    when it is not listed."""
    if choices is None:
        choices = _choices(settings)
    for e in choices:
        if e["load"] == load or (e["source"] != "shipped" and e["load"] == str(Path(load).resolve())):
            return str(e["name"])
    return Path(load).stem


def list_robots(settings: Settings) -> list[dict[str, Any]]:
    """Gives the robots a client may pick (GET /robots): name, source, default; never a server path."""
    return [{k: v for k, v in e.items() if k != "load"} for e in _choices(settings)]


def resolve_robot(name: str, settings: Settings, field: str = "robot") -> str:
    """Gives the string a simulation loads for the robot `name` (a shipped name or a file's full path), after loading
    it once; ApiError 422 naming `field` when the name is not listed or the robot cannot be loaded (its problems,
    as `footfall robot check` names them, without the server's paths)."""
    choices = _choices(settings)
    entry = next((e for e in choices if e["name"] == name), None)
    if entry is None:
        listed = ", ".join(e["name"] for e in choices)
        shown = name[:100] if isinstance(name, str) else repr(name)
        raise field_error(422, field, f"no robot {shown!r} (the robots: {listed}; GET /robots)")
    try:
        _load(str(entry["load"]))
    except Exception as e:  # noqa: BLE001 - any failure to load is the file's problem, told to the client
        message = _hide(f"{type(e).__name__}: {e}" if not isinstance(e, ValueError) else str(e), settings)
        raise field_error(422, field, f"robot {name!r} cannot be loaded: {message}"[:2000]) from None
    return str(entry["load"])


def _load(load: str) -> Any:
    from server.engine import _robot

    return _robot(load)  # the same cache the simulations load from


def _hide(message: str, settings: Settings) -> str:
    """Gives message without the server's robot directory or the server's robot's folder in it."""
    for root in (robot_dir(settings), Path(settings.robot).parent):
        for form in {str(root.resolve()), str(root)}:
            if form not in (".", ""):
                message = message.replace(form + os.sep, "")
    return message


__all__ = [
    "MAX_ROBOT_FILES", "ROBOT_NAME_RULE", "default_name", "list_robots", "name_of", "resolve_robot", "robot_dir",
]  # fmt: skip
