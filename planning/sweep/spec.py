"""The `footfall/sweep@1` file format: what a robustness sweep runs and which axes it varies.

A sweep names one run (a maneuver, a walk, or a trivial probe for measuring the tool itself) or a list of them,
defaults for every run parameter, and axes: each a list of values or a range. The cases are the full grid of the
axes' values, or N random samples drawn with a seed, each run once or, with `sampling.repeat`, once per value of a
nuisance axis. See README.md, "Robustness sweeps", for the fields and examples.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Annotated, Any, Literal

import yaml
from pydantic import AfterValidator, BaseModel, ConfigDict, Field, ValidationError, model_validator

from planning.terrain.spec import terrain_pipeline_name

FORMAT = "footfall/sweep@1"
MAX_CASES = 100_000  # the most cases one sweep may expand to
MAX_AXIS_VALUES = 10_000  # the most values one axis may list or a range may give
MAX_REPEAT_VALUES = 10  # the most values one repeat axis (sampling.repeat) may list
# The axis on which a repeated sweep's cases carry their draw's number (0..N-1): not an axis a spec may vary.
DRAW = "draw"
SHIPPED_SWEEPS = Path(__file__).resolve().parents[2] / "sweeps"

Scalar = float | int | str | bool
AxisValue = Scalar | list[float]  # a list of numbers: a range-valued scene parameter such as stones' gap_m


class _Model(BaseModel):
    model_config = ConfigDict(extra="forbid", frozen=True)


class Range(_Model):
    """Values from min to max: `count` evenly spaced (or every `step`) in a grid; uniform draws when sampled."""

    min: float
    max: float
    count: Annotated[int, Field(ge=1, le=MAX_AXIS_VALUES)] | None = Field(
        None, description="grid: this many values from min to max, both included"
    )
    step: Annotated[float, Field(gt=0)] | None = Field(None, description="grid: min, min+step, ... up to max")
    integer: bool = Field(False, description="whole numbers only (seeds, step counts)")

    @model_validator(mode="after")
    def _check(self) -> Range:
        if self.max < self.min:
            raise ValueError(f"max {self.max} is below min {self.min}")
        if self.count is not None and self.step is not None:
            raise ValueError("give count or step, not both")
        if self.step is not None and (self.max - self.min) / self.step + 1 > MAX_AXIS_VALUES:
            raise ValueError(f"step {self.step} gives more than {MAX_AXIS_VALUES} values")
        return self


Axis = Annotated[list[AxisValue], Field(min_length=1, max_length=MAX_AXIS_VALUES)] | Range


class Push(_Model):
    """A push on the body's center of mass: impulse_ns N·s over duration_s from t_s, horizontal, toward
    direction_deg (0: forward along +x, 90: left along +y). impulse_ns 0: no push."""

    t_s: Annotated[float, Field(ge=0)] = 1.0
    duration_s: Annotated[float, Field(gt=0, le=5)] = 0.1
    impulse_ns: Annotated[float, Field(ge=0, le=1000)] = 0.0
    direction_deg: float = 90.0


class Walk(_Model):
    """Steering mode: a goal (x, y m) to reach, or a velocity command."""

    goal: tuple[float, float] | Literal["terrain"] | None = Field(
        None,
        description="walk to this point (m); 'terrain': the terrain's own goal (its goal_x_m: 6 m, or 1 m past a "
        "terrain that ends beyond 5 m); None: velocity",
    )
    vx: Annotated[float, Field(ge=-5, le=5)] = 0.0
    vy: Annotated[float, Field(ge=-5, le=5)] = 0.0
    yaw_rate: Annotated[float, Field(ge=-5, le=5)] = 0.0
    gait: str = "trot"
    maps: Literal["sensor", "truth", "off"] = "sensor"
    terrain_pipeline: Annotated[str | None, AfterValidator(terrain_pipeline_name)] = Field(
        None,
        description="removed: there is one terrain pipeline; 'regions' (its name) is still accepted so that old "
        "specs run, any other value is refused",
    )
    solver: Literal["balance", "centroidal"] = "balance"
    stop_at_goal: bool = True
    speed_mps: Annotated[float | None, Field(gt=0, le=5)] = Field(
        None,
        description="a terrain walk's speed to its goal and cap on a steered command (m/s; `footfall walk --speed`); "
        "None: the terrain pipeline's own (0.5); within each terrain's range (0.2 to 0.5, 1.0 on slope and rough)",
    )
    descend_backward: bool | None = Field(
        None,
        description="a walk to a goal on a terrain goes down stairs backward where it has room to turn round "
        "(true; needs a goal and a terrain) or forward (false, `footfall walk --descend-forward`); None: the "
        "product's default (backward)",
    )


class Probe(_Model):
    """A trivial case that simulates nothing: it sleeps, then reports success (or failure every Nth case).
    For measuring the tool itself (scheduling cost, workers killed mid-case), not the robot."""

    sleep_s: Annotated[float, Field(ge=0, le=600)] = 0.0
    fail_every: Annotated[int, Field(ge=0)] = 0
    mark_dir: str | None = Field(None, description="write a file named by the worker's pid here on start")


class Run(_Model):
    """What one case runs: exactly one of maneuver, walk and probe; label names it in a list of runs."""

    label: str | None = None
    maneuver: str | None = Field(None, description="a library name or a .yaml path")
    walk: Walk | None = None
    probe: Probe | None = None
    axes: dict[str, Axis] = Field(
        default_factory=dict,
        description="axes of this run only: they replace the sweep's axes of the same name",
    )

    @model_validator(mode="after")
    def _one(self) -> Run:
        given = [k for k in ("maneuver", "walk", "probe") if getattr(self, k) is not None]
        if len(given) != 1:
            raise ValueError(
                f"give exactly one of maneuver, walk and probe (got {', '.join(given) or 'none'})"
            )
        return self

    def name(self) -> str:
        if self.label:
            return self.label
        if self.maneuver is not None:
            return Path(self.maneuver).stem
        return "walk" if self.walk is not None else "probe"


class Defaults(_Model):
    """Every case's parameters where no axis varies them."""

    robot: str = "spot"
    terrain: str = "flat"
    terrain_params: dict[str, AxisValue] = Field(default_factory=dict)
    seed: Annotated[int, Field(ge=0)] = 0
    duration_s: Annotated[float, Field(gt=0, le=600)] | None = Field(
        None, description="simulated seconds (None: the maneuver's, 10 s for a velocity walk, 30 s to a goal)"
    )
    push: Push = Field(default_factory=lambda: Push.model_validate({}))
    start_x_m: float = 0.0
    start_y_m: float = 0.0
    start_yaw_rad: float = 0.0
    friction: Annotated[float, Field(gt=0, le=3)] | None = None
    sensor_noise_m: Annotated[float, Field(ge=0, le=1)] | None = None
    goal_dx_m: float = 0.0
    goal_dy_m: float = 0.0


# The axes a sweep may vary (besides terrain.<parameter>), with what each sets.
AXES: dict[str, str] = {
    "run": "which of the listed runs (by label)",
    "maneuver": "a maneuver by library name",
    "robot": "robot description",
    "terrain": "terrain family (footfall terrains lists them)",
    "seed": "the terrain scene's seed (its layout)",
    "push_impulse_ns": "push impulse, N·s",
    "push_direction_deg": "push direction, degrees (0 forward, 90 left)",
    "push_t_s": "push time, s",
    "push_duration_s": "push duration, s",
    "start_x_m": "start position offset along x, m",
    "start_y_m": "start position offset along y, m",
    "start_yaw_rad": "start yaw offset, rad",
    "friction": "foot-ground sliding friction coefficient",
    "sensor_noise_m": "depth sensor range noise floor (1σ), m",
    "goal_dx_m": "goal offset along x, m",
    "goal_dy_m": "goal offset along y, m",
}


class Sampling(_Model):
    """N random cases: each axis's value drawn uniformly (from its list, or within its range), with a seed; with
    `repeat`, each draw runs once per combination of the repeat axes' values, its other axes' values the same."""

    random: Annotated[int, Field(ge=1, le=MAX_CASES)]
    seed: int = 0
    repeat: dict[str, Annotated[list[AxisValue], Field(min_length=1, max_length=MAX_REPEAT_VALUES)]] = Field(
        default_factory=dict,
        description="axis name → values each draw is run at (every combination across the repeat axes): a "
        "nuisance axis, such as a 1 mm start offset (start_x_m: [0.0, 0.001]), that tells a change's effect from "
        "chaos; the draws are the spec's without it, and each case carries its draw's number on the `draw` axis",
    )

    def repeats_per_draw(self) -> int:
        """How many cases each draw runs as: the product of the repeat axes' value counts (1 without repeat)."""
        return math.prod(len(v) for v in self.repeat.values())


class Summary(_Model):
    """How results are grouped: `by` axes make the cells (default: every axis with more than one value except
    seed); `heatmap` two axes to draw (default: the first two of `by`); `bins` for sampled numeric axes."""

    by: list[str] | None = None
    heatmap: tuple[str, str] | None = None
    bins: Annotated[int, Field(ge=1, le=100)] = 5
    success: Literal["report", "clean"] = Field(
        "report",
        description="what counts as a success: the run report's verdict, or 'clean': that and no body collision and "
        "no touchdown in a no-step cell (a terrain crossing's measure)",
    )


class SweepSpec(_Model):
    """A robustness sweep: runs × axes → cases, each one headless run with its own run report."""

    model_config = ConfigDict(extra="forbid", frozen=True, title="footfall sweep (footfall/sweep@1)")

    format: Literal["footfall/sweep@1"] = Field(description="always footfall/sweep@1")
    name: str = Field(pattern=r"^[a-z0-9]+(-[a-z0-9]+)*$", max_length=64)
    description: str = Field("", max_length=10_000)
    run: Run | Annotated[list[Run], Field(min_length=1, max_length=100)]
    defaults: Defaults = Field(default_factory=lambda: Defaults.model_validate({}))
    axes: dict[str, Axis] = Field(
        default_factory=dict,
        description="axis name → values; names: " + ", ".join(AXES) + ", or terrain.<scene parameter>",
    )
    sampling: Literal["grid"] | Sampling = "grid"
    summary: Summary = Field(default_factory=lambda: Summary.model_validate({}))
    timeout_s: Annotated[float, Field(gt=0, le=86_400)] | None = Field(
        None, description="a case running longer than this (wall clock) is stopped and counted as crashed"
    )

    def runs(self) -> list[Run]:
        return list(self.run) if isinstance(self.run, list) else [self.run]

    def repeat(self) -> dict[str, list[AxisValue]]:
        """The axes each random draw is repeated over, with their values (sampling.repeat; empty for a grid)."""
        return {} if isinstance(self.sampling, str) else dict(self.sampling.repeat)

    @model_validator(mode="after")
    def _check_axes(self) -> SweepSpec:
        drawn: list[tuple[str, dict[str, Any]]] = [("axes", self.axes)]
        drawn += [(f"run.{r.name()}.axes", r.axes) for r in self.runs()]
        for where, axes in [*drawn, ("sampling.repeat", self.repeat())]:
            for name in axes:
                if name not in AXES and not name.startswith("terrain."):
                    raise ValueError(
                        f"{where}.{name}: unknown axis (one of: {', '.join(AXES)}, terrain.<parameter>)"
                    )
                if name == "run":
                    raise ValueError(
                        f"{where}.run: list the runs under `run:` instead; the list is the run axis"
                    )
        for name in self.repeat():
            for where, axes in drawn:
                if name in axes:
                    raise ValueError(
                        f"sampling.repeat.{name}: also {where}.{name}; an axis is either drawn or repeated"
                    )
        if isinstance(self.sampling, Sampling) and self.sampling.repeat:
            per = self.sampling.repeats_per_draw()
            if self.sampling.random * per > MAX_CASES:
                raise ValueError(
                    f"sampling.repeat: {self.sampling.random} draws × {per} repeats is "
                    f"{self.sampling.random * per} cases, over the {MAX_CASES} a sweep may run"
                )
        labels = [r.name() for r in self.runs()]
        if len(set(labels)) != len(labels):
            raise ValueError(f"run: labels must differ (got {labels}); give each a label")
        return self


class SweepSpecError(ValueError):
    """A sweep spec that does not load: every problem as `field: reason`."""

    def __init__(self, problems: list[str], source: str | None = None) -> None:
        self.problems = problems
        self.source = source
        head = f"{source}: " if source else ""
        super().__init__(head + "; ".join(problems))


def _problems(e: ValidationError) -> list[str]:
    out = []
    for err in e.errors(include_url=False):
        loc = ".".join(str(p) for p in err["loc"] if not str(p).startswith(("function-", "tagged-union")))
        msg = err["msg"].removeprefix("Value error, ")
        out.append(f"{loc}: {msg}" if loc else msg)  # a whole-document check names its field itself
    return out


def parse_spec(data: Any, source: str | None = None) -> SweepSpec:
    """Returns the SweepSpec of a parsed document; raises SweepSpecError naming each bad field."""
    if not isinstance(data, dict):
        raise SweepSpecError(["a sweep spec must be a mapping (format, name, run, axes, ...)"], source)
    try:
        return SweepSpec.model_validate(data)
    except ValidationError as e:
        # a union's alternatives each give an error; keep the distinct ones
        raise SweepSpecError(list(dict.fromkeys(_problems(e))), source) from None


def find_spec(name_or_path: str) -> Path:
    """Returns the file of a shipped sweep by name (sweeps/NAME.yaml) or of a path."""
    p = Path(name_or_path)
    if p.is_file():
        return p
    if "/" not in name_or_path and not name_or_path.endswith((".yaml", ".yml")):
        q = SHIPPED_SWEEPS / f"{name_or_path}.yaml"
        if q.is_file():
            return q
        known = sorted(f.stem for f in SHIPPED_SWEEPS.glob("*.yaml"))
        raise SweepSpecError([f"no shipped sweep named {name_or_path!r} (shipped: {', '.join(known)})"])
    raise SweepSpecError([f"no such file: {p}"])


def load_spec(name_or_path: str | Path) -> SweepSpec:
    """Returns the SweepSpec of a file (or a shipped sweep's name); raises SweepSpecError."""
    path = find_spec(str(name_or_path))
    try:
        data = yaml.safe_load(path.read_text(encoding="utf-8"))
    except (OSError, UnicodeDecodeError) as e:
        raise SweepSpecError([f"cannot read: {e}"], str(path)) from None
    except yaml.YAMLError as e:
        raise SweepSpecError([f"not YAML: {e}"], str(path)) from None
    return parse_spec(data, str(path))


def sweep_json_schema() -> dict[str, Any]:
    """Returns the JSON Schema (draft 2020-12) of a sweep spec file."""
    return {
        "$schema": "https://json-schema.org/draft/2020-12/schema",
        "$id": "urn:footfall:sweep@1",
        **SweepSpec.model_json_schema(mode="validation"),
    }
