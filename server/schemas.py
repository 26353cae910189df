"""Request and response bodies of the REST API (pydantic at the boundary only), in families per resource.

Numbers are strict (a string "1.0" is not a number) and finite; every model forbids unknown fields, so a typo is
answered with the field's name instead of being ignored. Units: meters, seconds, newtons, radians per second.
"""

from __future__ import annotations

from typing import Annotated, Any, Literal

from pydantic import (
    AfterValidator,
    BaseModel,
    ConfigDict,
    Field,
    WithJsonSchema,
    field_validator,
    model_validator,
)

from planning.maneuver.spec import NAME_PATTERN
from planning.terrain.spec import terrain_pipeline_name
from server.engine import steering_gaits, terrain_names

TerrainName = Literal[terrain_names()]  # type: ignore[valid-type]


class TerrainObjectIn(BaseModel):
    """A terrain in the structured form: a built-in name or an uploaded file, with parameters."""

    model_config = ConfigDict(extra="forbid", allow_inf_nan=False)
    name: TerrainName | None = Field(None, description="a built-in terrain (GET /terrains)")  # type: ignore[valid-type]
    file: Annotated[str, Field(max_length=100)] | None = Field(
        None, description="an uploaded terrain file (GET /terrain-files)"
    )
    params: Annotated[dict[str, Any], Field(max_length=40)] = Field(
        default_factory=dict,
        description="parameter overrides (GET /terrains lists each terrain's, with ranges); a range as [min, max]",
    )


def _terrain_text(v: Any) -> str:
    """Gives the string form of a terrain field (checked: known name, known parameters in range, bare file name)."""
    from server.terrains import parse_network_terrain

    raw = v.model_dump(exclude_none=True) if isinstance(v, TerrainObjectIn) else v
    return parse_network_terrain(raw).text()


TerrainIn = Annotated[
    Annotated[str, Field(max_length=2000)] | TerrainObjectIn,
    AfterValidator(_terrain_text),
    Field(
        description="a built-in name (GET /terrains), a name with parameters (stairs:riser_m=0.18,tread_m=0.28), "
        "an uploaded file (hills.npy:cell_m=0.05, room.xml; GET /terrain-files), or the structured form "
        '{"name": "stairs", "params": {"riser_m": 0.18}}',
        examples=["stairs:riser_m=0.18,tread_m=0.28"],
    ),
]
SteerGait = Literal[steering_gaits() or ("trot", "walk", "pace", "bound")]  # type: ignore[valid-type]


def _num(lo: float, hi: float, *, lo_open: bool = False) -> Any:
    if lo_open:
        return Annotated[float, Field(strict=True, allow_inf_nan=False, gt=lo, le=hi)]
    return Annotated[float, Field(strict=True, allow_inf_nan=False, ge=lo, le=hi)]


Force = Annotated[float, Field(strict=True, allow_inf_nan=False, ge=-5000.0, le=5000.0)]
Vec3Force = Annotated[
    list[Force], Field(min_length=3, max_length=3, description="[fx, fy, fz], N, world frame")
]


class _In(BaseModel):
    model_config = ConfigDict(extra="forbid", allow_inf_nan=False)


# ---- pushes -----------------------------------------------------------------------------------------------------
class PushIn(_In):
    """A force on the body's center of mass: from t for duration (a scheduled push in a headless run)."""

    t: _num(0.0, 600.0) = Field(description="start time, s")  # type: ignore[valid-type]
    force: Vec3Force
    duration: _num(0.0, 5.0, lo_open=True) = Field(0.1, description="s")  # type: ignore[valid-type]


PushSpec = Annotated[
    str,
    Field(
        max_length=100,
        description="T:FX,FY,FZ[:DURATION] as on the command line",
        examples=["1.0:0,150,0:0.1"],
    ),
]


# ---- simulations ------------------------------------------------------------------------------------------------
class WalkIn(_In):
    """A steering-mode run: velocity commands (or a goal) instead of a maneuver."""

    vx: _num(-2.5, 2.5) = 0.0  # type: ignore[valid-type]
    vy: _num(-1.0, 1.0) = 0.0  # type: ignore[valid-type]
    yaw_rate: _num(-2.0, 2.0) = 0.0  # type: ignore[valid-type]
    gait: SteerGait = "trot"  # type: ignore[valid-type]
    goal: Annotated[list[_num(-100.0, 100.0)], Field(min_length=2, max_length=2)] | None = None  # type: ignore[valid-type]
    maps: Literal["sensor", "truth", "off"] = Field(
        "sensor",
        description="on a terrain: the simulated depth sensor's maps, the scene's own (perfect perception), or none",
    )
    terrain_speed: _num(0.2, 1.0) | None = Field(  # type: ignore[valid-type]
        None,
        description="on a terrain: the speed to the goal and the cap on vx/vy, m/s (default 0.5; up to 1.0 on "
        "slope and rough, 0.5 elsewhere; the terrain's own caps still apply)",
    )
    terrain_pipeline: Annotated[str | None, AfterValidator(terrain_pipeline_name)] = Field(
        None,
        max_length=64,
        description="removed: there is one terrain pipeline; 'regions' (its name) is still accepted, any other "
        "value is refused",
    )
    descend_backward: bool = Field(
        True,
        description="on a terrain, walking to a goal: go down descents (stairs) backward where there is room to "
        "turn round (false: facing the way the walk goes)",
    )


# a library name: documented with its pattern, checked by the library (its message says what a name is)
ManeuverName = Annotated[
    str,
    Field(
        max_length=64, json_schema_extra={"pattern": NAME_PATTERN}, description="a library maneuver's name"
    ),
]
InlineManeuver = Annotated[dict[str, Any], WithJsonSchema({"$ref": "#/components/schemas/Maneuver"})]


def _exactly_one_of(*keys: str) -> Any:
    """Returns a json_schema_extra that says "exactly one of these fields, none of them null" (oneOf/required)."""

    def extra(schema: dict[str, Any], cls: Any) -> None:
        for key in keys:
            prop = schema["properties"][key]
            options = [o for o in prop.pop("anyOf", []) if o != {"type": "null"}]
            if options:
                prop.update(options[0] if len(options) == 1 else {"anyOf": options})
            prop.pop("default", None)
        schema["oneOf"] = [{"required": [key]} for key in keys]

    return extra


RobotName = Annotated[
    str,
    Field(
        max_length=64,
        description="a robot GET /robots lists (default: the server's robot)",
        examples=["go1"],
    ),
]


class SimulationCreate(_In):
    """A queued headless run: a maneuver (library name or inline document) or a walk, on a terrain."""

    model_config = ConfigDict(json_schema_extra=_exactly_one_of("maneuver", "walk"))

    maneuver: ManeuverName | InlineManeuver | None = Field(
        None, description="a library name, or a maneuver document (footfall/maneuver@1) inline"
    )
    walk: WalkIn | None = None
    terrain: TerrainIn = "flat"
    robot: RobotName | None = None
    pushes: Annotated[list[PushIn | PushSpec], Field(max_length=50)] = Field(default_factory=list)
    duration: _num(0.0, 120.0, lo_open=True) | None = Field(  # type: ignore[valid-type]
        None, description="simulated seconds (default: the maneuver's)"
    )

    @model_validator(mode="before")
    @classmethod
    def _no_nulls(cls, data: Any) -> Any:
        if isinstance(data, dict):
            for key in ("maneuver", "walk"):
                if key in data and data[key] is None:
                    raise ValueError(
                        f"{key}: must not be null; leave it out (give exactly one of maneuver or walk)"
                    )
        return data

    @model_validator(mode="after")
    def _one_of(self) -> SimulationCreate:
        if (self.maneuver is None) == (self.walk is None):
            raise ValueError("give exactly one of maneuver or walk")
        return self


class SimulationAccepted(BaseModel):
    id: str
    status: str
    url: str


class SimulationPublic(BaseModel):
    """A simulation's status; `report` is the run report (CONTRACT.md) once done."""

    id: str
    status: Literal["queued", "running", "done", "failed", "cancelled"]
    request: dict[str, Any]
    created: float
    started: float | None = None
    finished: float | None = None
    progress: dict[str, float] | None = None
    report: dict[str, Any] | None = None
    error: str | None = None
    queue_position: int | None = None


# ---- sessions ---------------------------------------------------------------------------------------------------
# what a live session's terrain walk plans on: the scene's own maps, or the simulated depth sensor's
SessionMaps = Literal["truth", "sensor"]


class SessionCreate(_In):
    terrain: TerrainIn = "flat"
    robot: RobotName | None = None
    mode: Literal["steer", "maneuver"] = "maneuver"
    maps: SessionMaps = Field(
        "truth",
        description="on a terrain, what a walk plans on: the scene's own maps (keeps real time) or the simulated "
        "depth sensor's (slower than real time; its scans show as the depth_cloud overlay)",
    )


class SessionCreated(BaseModel):
    id: str
    terrain: str
    robot: str
    mode: str
    maps: str
    state_url: str


class SteerIn(_In):
    """A velocity command in the body's heading frame: m/s, m/s, rad/s."""

    vx: _num(-2.5, 2.5) = 0.0  # type: ignore[valid-type]
    vy: _num(-1.0, 1.0) = 0.0  # type: ignore[valid-type]
    yaw_rate: _num(-2.0, 2.0) = 0.0  # type: ignore[valid-type]
    gait: SteerGait = "trot"  # type: ignore[valid-type]
    weights: Literal["default", "precise_footing", "stable_body"] | None = Field(
        None, description="step selection weights (Qp, Qr) preset; None keeps the current ones"
    )


class SessionManeuverIn(_In):
    """Start a maneuver: from the stance at the origin, at `speed` times real time."""

    maneuver: ManeuverName | InlineManeuver
    speed: _num(0.05, 4.0) | None = None  # type: ignore[valid-type]


class SessionPushIn(_In):
    """A push now: a force (N, world frame) on the body's center of mass for `duration` s."""

    force: Vec3Force
    duration: _num(0.0, 2.0, lo_open=True) = 0.1  # type: ignore[valid-type]


class SessionResetIn(_In):
    terrain: TerrainIn | None = None
    robot: RobotName | None = None
    maps: SessionMaps | None = None


class SessionControlIn(_In):
    """Playback control: play, pause or restart the current maneuver; speed in times real time."""

    action: Literal["play", "pause", "restart"] | None = None
    speed: _num(0.05, 4.0) | None = None  # type: ignore[valid-type]


class StudioPreviewIn(_In):
    maneuver: ManeuverName
    terrain: TerrainIn = "flat"

    @field_validator("maneuver")
    @classmethod
    def _name(cls, v: str) -> str:
        from server.storage import check_name

        check_name(v)
        return v
