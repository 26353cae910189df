"""The editor's fields read off the maneuver format's pydantic models: their limits, defaults, choices and help.

The studio's number inputs must accept exactly what a maneuver file accepts, so nothing here restates a limit: a
bound is the model's (`ge`, `gt`, `le`, `lt`), an open bound becomes the nearest value a step away, a field with no
upper bound gets the format's longest duration for times and `UNBOUNDED` otherwise.
"""

from __future__ import annotations

import typing
from dataclasses import dataclass
from typing import Any

import annotated_types as at
from pydantic import BaseModel

from planning.maneuver import spec

UNBOUNDED = 1.0e6  # the largest value a number input offers where the format sets no upper bound


@dataclass(frozen=True)
class NumberField:
    """What a number input of one model field offers: [lo, hi] (open bounds already a step inside), its default
    (None when required) and its description (shown as the input's hint)."""

    lo: float
    hi: float
    default: float | None
    description: str | None


def _bounds(metadata: list[Any]) -> tuple[float | None, bool, float | None, bool]:
    lo = hi = None
    lo_open = hi_open = False
    for m in metadata:
        for c in getattr(m, "metadata", [m]):  # a nested Annotated keeps its own metadata
            if isinstance(c, at.Ge):
                lo, lo_open = float(c.ge), False  # type: ignore[arg-type]
            elif isinstance(c, at.Gt):
                lo, lo_open = float(c.gt), True  # type: ignore[arg-type]
            elif isinstance(c, at.Le):
                hi, hi_open = float(c.le), False  # type: ignore[arg-type]
            elif isinstance(c, at.Lt):
                hi, hi_open = float(c.lt), True  # type: ignore[arg-type]
    return lo, lo_open, hi, hi_open


def number(model: type[BaseModel], name: str, step: float, *, is_time: bool = False) -> NumberField:
    """Returns the limits of `model.name` for a number input stepping by `step`."""
    f = model.model_fields[name]
    lo, lo_open, hi, hi_open = _bounds(list(f.metadata))
    if lo is None or hi is None:  # bounds carried by the type alias (Time, NonNegative, ...) of an Optional
        for arg in typing.get_args(f.annotation) or (f.annotation,):
            meta = getattr(arg, "__metadata__", None)
            if meta:
                a_lo, a_lo_open, a_hi, a_hi_open = _bounds(list(meta))
                if lo is None and a_lo is not None:
                    lo, lo_open = a_lo, a_lo_open
                if hi is None and a_hi is not None:
                    hi, hi_open = a_hi, a_hi_open
    lo_v = (lo + step if lo_open else lo) if lo is not None else -UNBOUNDED
    hi_v = (
        (hi - step if hi_open else hi) if hi is not None else (spec.MAX_DURATION_S if is_time else UNBOUNDED)
    )
    default = f.default if isinstance(f.default, (int, float)) and not isinstance(f.default, bool) else None
    if f.default_factory is not None:
        default = None
    return NumberField(float(lo_v), float(hi_v), None if default is None else float(default), f.description)


def choices(model: type[BaseModel], name: str) -> tuple[str, ...]:
    """Returns the values a Literal field allows (e.g. the gait names)."""
    ann = model.model_fields[name].annotation
    for arg in (ann, *typing.get_args(ann)):
        if typing.get_origin(arg) is typing.Literal:
            return tuple(str(v) for v in typing.get_args(arg))
    raise TypeError(f"{model.__name__}.{name} is not a Literal field")


def objective_models() -> dict[str, type[BaseModel]]:
    """Returns the objective kinds by their `type` name (maximize_height, lean, minimize_torque)."""
    union = typing.get_args(spec.Objective)[0]
    return {choices(m, "type")[0]: m for m in typing.get_args(union)}


def weight_defaults() -> dict[str, float]:
    """Returns the planner's cost weights by name with their defaults, in the format's order."""
    return {k: float(f.default) for k, f in spec.Weights.model_fields.items()}


MANEUVER = spec.Maneuver
GAIT = spec.Gait
KEYFRAME = spec.Keyframe
TOUCHDOWN = spec.Touchdown
LIFTOFF = spec.Liftoff
ADJUST = spec.Adjust
WEIGHTS = spec.Weights
GAITS = choices(spec.Gait, "gait")
OBJECTIVES = tuple(objective_models())
