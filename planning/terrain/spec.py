"""What ``--terrain`` (and the REST API's ``terrain`` field) names, parsed and loaded into a TerrainScene.

Forms (the string form; the structured form is the same as a mapping, see ``spec_from_mapping``):

- ``NAME``: a built-in family with its defaults (``footfall terrains`` lists them);
- ``NAME:KEY=VALUE,KEY=VALUE``: with parameter overrides, e.g. ``stairs:riser_m=0.18,tread_m=0.28``. Values:
  numbers, ``true``/``false``, ``auto`` (for a goal), and ``MIN..MAX`` for a range (``gap_m=0.15..0.25``; one
  number means a fixed value);
- ``PATH[:KEY=VALUE,...]``: a file, ``.xml`` for an MJCF scene, ``.npy`` or ``.png`` for a heightmap, e.g.
  ``heightmap.npy:cell_m=0.05``. A YAML file beside a heightmap (same name, ``.yaml``) may give its keys; the
  ones in the string win.

Every error is a TerrainSpecError naming the bad key or value and listing the valid ones.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from planning.terrain.scenes import (
    TERRAIN_NAMES,
    ParamInfo,
    TerrainParamError,
    TerrainScene,
    build_from_params,
    param_info,
)
from planning.terrain.userscene import (
    HEIGHTMAP_SUFFIXES,
    MJCF_SUFFIXES,
    HeightmapParams,
    MjcfSceneParams,
    UserTerrainError,
    heightmap_scene,
    mjcf_scene,
)

FILE_SUFFIXES = MJCF_SUFFIXES + HEIGHTMAP_SUFFIXES
MAX_SPEC_CHARS = 2000  # longest terrain string accepted


# The terrain pipeline's name (`terrain_pipeline` in sweep specs, REST walks, `footfall walk --terrain-pipeline`): there
# is one (planning.terrain.decision); "regions" is still accepted so that old specs run, any other name is refused.
TERRAIN_PIPELINE = "regions"
PIPELINE_REMOVED = "removed: there is one terrain pipeline (steppable regions; 'regions' is still accepted)"


def check_terrain_pipeline(name: str | None) -> str | None:
    """Gives why a terrain pipeline name (from a spec, a request, the command line) is refused, or None."""
    if name is None or name == TERRAIN_PIPELINE:
        return None
    return f"{name!r}: {PIPELINE_REMOVED}"


def terrain_pipeline_name(name: str | None) -> str | None:
    """A pydantic after-validator for a `terrain_pipeline` field (sweep specs, REST requests): the name, or a
    ValueError saying why it is refused."""
    why = check_terrain_pipeline(name)
    if why is not None:
        raise ValueError(why)
    return name


class TerrainSpecError(ValueError):
    """A terrain that cannot be named or built; the message names the key or value and what is valid."""


@dataclass(frozen=True)
class TerrainSpec:
    """A parsed terrain: a built-in family (name) or a file (path), with typed overrides in declaration order."""

    name: str | None = None
    path: str | None = None
    overrides: tuple[tuple[str, Any], ...] = ()

    @property
    def family(self) -> str:
        """Gives the family: a built-in name, "mjcf" or "heightmap"."""
        if self.name is not None:
            return self.name
        assert self.path is not None
        return "mjcf" if Path(self.path).suffix.lower() in MJCF_SUFFIXES else "heightmap"

    def text(self) -> str:
        """Gives the string form, e.g. ``stairs:riser_m=0.18,tread_m=0.28``."""
        head = self.name if self.name is not None else str(self.path)
        if not self.overrides:
            return head
        return head + ":" + ",".join(f"{k}={_format(v)}" for k, v in self.overrides)


def _format(v: Any) -> str:
    if v is None:
        return "auto"
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, tuple):
        return f"{_format(v[0])}..{_format(v[1])}"
    if isinstance(v, float) and v.is_integer():
        return str(int(v)) if abs(v) < 1e15 else repr(v)
    return str(v)


def _valid_keys(infos: tuple[ParamInfo, ...]) -> str:
    return "; ".join(i.describe() for i in infos if i.name != "path")


def _infos(family: str) -> tuple[ParamInfo, ...]:
    if family == "heightmap":
        return _user_infos(HeightmapParams)
    if family == "mjcf":
        return _user_infos(MjcfSceneParams)
    return param_info(family)


def _user_infos(cls: type) -> tuple[ParamInfo, ...]:
    from planning.terrain.scenes import _info

    return tuple(_info(f) for f in dataclasses.fields(cls))


def _coerce(family: str, info: ParamInfo, raw: Any, strict: bool) -> Any:
    """Gives raw (a string from the string form, or a JSON value) as the parameter's kind; strict (the structured
    form): numbers and booleans must be JSON numbers and booleans, not strings."""
    where = f"{family}: {info.name}={raw!r}"
    if strict and isinstance(raw, str) and info.kind != "str":
        want = {"bool": "true or false", "range": "[MIN, MAX] or one number"}.get(info.kind, "a number")
        raise TerrainSpecError(f"{where}: expected {want}, not text")
    if info.kind == "bool":
        if isinstance(raw, bool):
            return raw
        if isinstance(raw, str) and raw.lower() in ("true", "yes", "on", "1", "false", "no", "off", "0"):
            return raw.lower() in ("true", "yes", "on", "1")
        raise TerrainSpecError(f"{where}: expected true or false")
    if info.kind == "range":
        if isinstance(raw, str):
            parts = raw.split("..")
            if len(parts) not in (1, 2):
                raise TerrainSpecError(f"{where}: expected MIN..MAX (e.g. 0.15..0.25) or one number")
            vals = [_number(where, p) for p in parts]
            return (vals[0], vals[-1])
        if isinstance(raw, int | float) and not isinstance(raw, bool):
            return (float(raw), float(raw))
        if isinstance(raw, list | tuple) and len(raw) == 2:
            return (_number(where, raw[0]), _number(where, raw[1]))
        raise TerrainSpecError(f"{where}: expected [MIN, MAX], MIN..MAX or one number")
    if info.kind == "float | None" and (raw is None or (isinstance(raw, str) and raw.lower() == "auto")):
        return None
    if info.kind == "str":
        if not isinstance(raw, str):
            raise TerrainSpecError(f"{where}: expected text")
        return raw
    x = _number(where, raw)
    if info.kind == "int":
        if not x.is_integer():
            raise TerrainSpecError(f"{where}: expected a whole number")
        return int(x)
    return x


def _number(where: str, raw: Any) -> float:
    if isinstance(raw, bool):
        raise TerrainSpecError(f"{where}: expected a number")
    try:
        x = float(raw.strip()) if isinstance(raw, str) else float(raw)
    except (TypeError, ValueError):
        raise TerrainSpecError(f"{where}: expected a number") from None
    if not math.isfinite(x):
        raise TerrainSpecError(f"{where}: must be finite")
    return x


def _typed(family: str, pairs: list[tuple[str, Any]], strict: bool = False) -> tuple[tuple[str, Any], ...]:
    infos = {i.name: i for i in _infos(family)}
    out: dict[str, Any] = {}
    for key, raw in pairs:
        info = infos.get(key)
        if info is None or key == "path":
            raise TerrainSpecError(
                f"{family}: unknown parameter {key!r}; valid: {_valid_keys(tuple(infos.values()))}"
            )
        if key in out:
            raise TerrainSpecError(f"{family}: parameter {key!r} is given twice")
        out[key] = _coerce(family, info, raw, strict)
    return tuple(out.items())


def _looks_like_file(text: str) -> bool:
    path, _, rest = text.rpartition(":")
    if not path or "=" not in rest:
        path = text
    return "/" in path or "\\" in path or Path(path).suffix != ""


def _unknown(text: str) -> TerrainSpecError:
    return TerrainSpecError(
        f"unknown terrain {text!r}; valid: {', '.join(TERRAIN_NAMES)}, a name with parameters "
        "(stairs:riser_m=0.18,tread_m=0.28), or a file: an MJCF scene (.xml) or a heightmap (.npy, .png)"
    )


def parse_terrain(text: str) -> TerrainSpec:
    """Gives the TerrainSpec of a ``--terrain`` string (see the module docstring); TerrainSpecError if malformed.
    Files are not read (see load_terrain), so a path need not exist yet."""
    if not isinstance(text, str) or not text.strip():
        raise TerrainSpecError("terrain: empty; give a name (footfall terrains lists them) or a file")
    if len(text) > MAX_SPEC_CHARS:
        raise TerrainSpecError(f"terrain: {len(text)} characters, more than {MAX_SPEC_CHARS}")
    text = text.strip()
    name, sep, rest = text.partition(":")
    if name in TERRAIN_NAMES:
        return TerrainSpec(name=name, overrides=_typed(name, _pairs(name, rest)) if sep else ())
    if not _looks_like_file(text):
        raise _unknown(text)
    # A path: options follow the last ':' when they look like KEY=VALUE (a path may hold ':' itself).
    path, sep, rest = text.rpartition(":")
    if not sep or "=" not in rest or not path:
        path, rest = text, ""
    suffix = Path(path).suffix.lower()
    if suffix not in FILE_SUFFIXES:
        raise TerrainSpecError(
            f"terrain file {path!r}: unknown kind {suffix or '(no suffix)'!r}; an MJCF scene is .xml, a "
            "heightmap .npy or .png"
        )
    spec = TerrainSpec(path=path)
    return dataclasses.replace(spec, overrides=_typed(spec.family, _pairs(spec.family, rest)) if rest else ())


def _pairs(family: str, rest: str) -> list[tuple[str, str]]:
    out = []
    for item in rest.split(","):
        key, eq, value = item.partition("=")
        if not eq or not key.strip() or not value.strip():
            raise TerrainSpecError(
                f"{family}: {item!r} is not KEY=VALUE (e.g. riser_m=0.18); valid keys: "
                f"{_valid_keys(_infos(family))}"
            )
        out.append((key.strip(), value.strip()))
    return out


def spec_from_mapping(m: Mapping[str, Any]) -> TerrainSpec:
    """Gives the TerrainSpec of the structured form: ``{"name": "stairs", "params": {"riser_m": 0.18}}`` or
    ``{"file": "scene.xml", "params": {...}}`` (params optional; ranges as [min, max])."""
    keys = set(m)
    unknown = sorted(keys - {"name", "file", "params"})
    if unknown:
        raise TerrainSpecError(f"terrain: unknown field(s) {', '.join(unknown)}; valid: name or file, params")
    if ("name" in keys) == ("file" in keys):
        raise TerrainSpecError("terrain: give exactly one of name (a built-in terrain) or file")
    params = m.get("params") or {}
    if not isinstance(params, Mapping):
        raise TerrainSpecError("terrain.params: expected an object of parameter: value")
    if "name" in keys:
        name = m["name"]
        if not isinstance(name, str) or name not in TERRAIN_NAMES:
            raise TerrainSpecError(
                f"terrain.name {name!r}: unknown terrain; valid: {', '.join(TERRAIN_NAMES)}"
            )
        return TerrainSpec(name=name, overrides=_typed(name, list(params.items()), strict=True))
    path = m["file"]
    if not isinstance(path, str) or Path(path).suffix.lower() not in FILE_SUFFIXES:
        raise TerrainSpecError(f"terrain.file {path!r}: an MJCF scene (.xml) or a heightmap (.npy, .png)")
    spec = TerrainSpec(path=path)
    return dataclasses.replace(spec, overrides=_typed(spec.family, list(params.items()), strict=True))


def as_spec(terrain: str | TerrainSpec | Mapping[str, Any]) -> TerrainSpec:
    """Gives the TerrainSpec of any accepted form: a string, a mapping (structured form) or a TerrainSpec."""
    if isinstance(terrain, TerrainSpec):
        return terrain
    if isinstance(terrain, Mapping):
        return spec_from_mapping(terrain)
    return parse_terrain(terrain)


def _sidecar(path: Path) -> list[tuple[str, Any]]:
    """Gives the keys of the YAML beside a heightmap (same name, .yaml or .yml), if there is one."""
    import yaml

    for suffix in (".yaml", ".yml"):
        side = path.with_suffix(suffix)
        if side.is_file():
            try:
                doc = yaml.safe_load(side.read_text())
            except (yaml.YAMLError, OSError, UnicodeDecodeError) as e:
                raise TerrainSpecError(f"{side}: not readable YAML ({e})") from None
            if doc is None:
                return []
            if not isinstance(doc, dict):
                raise TerrainSpecError(f"{side}: expected a mapping of KEY: VALUE (e.g. cell_m: 0.05)")
            return [(str(k), v) for k, v in doc.items()]
    return []


def load_terrain(
    terrain: str | TerrainSpec | Mapping[str, Any], seed: int = 0, base_dir: Path | None = None
) -> TerrainScene:
    """Gives the scene a terrain names (any form of as_spec), built with `seed`. Relative file paths are taken from
    base_dir (default: the working directory). TerrainSpecError (a ValueError) names what is wrong."""
    spec = as_spec(terrain)
    try:
        if spec.name is not None:
            from planning.terrain.scenes import terrain_params

            return build_from_params(terrain_params(spec.name, **dict(spec.overrides)), seed)
        assert spec.path is not None
        path = Path(spec.path)
        if base_dir is not None and not path.is_absolute():
            path = base_dir / path
        overrides = dict(spec.overrides)
        if spec.family == "heightmap":
            side = dict(_typed("heightmap", _sidecar(path), strict=True))
            if "cell_m" not in side and "cell_m" not in overrides:
                raise TerrainSpecError(
                    f"{path}: a heightmap needs cell_m, the spacing of its samples (m): {path.name}:cell_m=0.05, "
                    f"or cell_m: 0.05 in {path.stem}.yaml beside it"
                )
            hp = HeightmapParams(path=str(path), **{**side, **overrides})
            return heightmap_scene(hp, seed)
        return mjcf_scene(MjcfSceneParams(path=str(path), **overrides), seed)
    except (TerrainParamError, UserTerrainError) as e:
        raise TerrainSpecError(str(e)) from None
