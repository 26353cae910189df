"""The `footfall/maneuver@1` file format as pydantic models: what a maneuver says, checked field by field.

These models check *shape* (types, ranges, required fields, no unknown fields). Rules that relate fields to each
other (events in order, touchdowns after liftoffs, reach) live in ``validate.py`` so that every problem of a file is
reported at once. Units: meters, seconds from the maneuver's start, degrees; frame: the maneuver frame (origin on the
ground under the body center at the start, x forward, y left, z up).
"""

from __future__ import annotations

from typing import Annotated, Any, Literal

from pydantic import BaseModel, BeforeValidator, ConfigDict, Field, model_validator
from pydantic_core import PydanticCustomError

FORMAT = "footfall/maneuver@1"
MAX_DURATION_S = 60.0
NAME_PATTERN = r"^[a-z0-9]+(-[a-z0-9]+)*$"

LegName = Literal["FL", "FR", "RL", "RR"]
GaitName = Literal["trot", "walk", "pace", "bound", "pronk"]
TrackName = Literal["legs", "body"]

# A real number: ints are fine, booleans and strings are not (strict), NaN/inf rejected by the model config.
# Bounded at ±1000 (meters, degrees, seconds): a maneuver is meters wide; 1e308 is a typo, not a plan.
MAX_COORDINATE = 1000.0
Real = Annotated[float, Field(strict=True, ge=-MAX_COORDINATE, le=MAX_COORDINATE)]
MAX_WEIGHT = 1000.0  # cost weights: the defaults are 1e-4 to 10; beyond this the solver's numbers break down
MAX_ADJUST_S = 2.0  # how far an event may move in time, s
MAX_LENGTH_M = 1.0  # adjust radius, swing height: a leg is under a meter long
Time = Annotated[float, Field(strict=True, ge=0.0, le=MAX_DURATION_S)]
Positive = Annotated[float, Field(strict=True, gt=0.0)]
NonNegative = Annotated[float, Field(strict=True, ge=0.0)]
Weight = Annotated[float, Field(strict=True, ge=0.0, le=MAX_WEIGHT)]
AdjustTime = Annotated[float, Field(strict=True, ge=0.0, le=MAX_ADJUST_S)]
Length = Annotated[float, Field(strict=True, gt=0.0, le=MAX_LENGTH_M)]


def _vector(n: int, labels: str) -> Any:
    """Returns a check that the input is a list of exactly n items, with a message naming the components."""

    def check(value: Any) -> Any:
        if isinstance(value, (list, tuple)) and len(value) == n:
            return value
        got = f"{len(value)} items" if isinstance(value, (list, tuple)) else repr(value)
        raise PydanticCustomError(
            "vector",
            "must be a list of {n} numbers {labels}, got {got}",
            {"n": n, "labels": labels, "got": got},
        )

    return BeforeValidator(check)


def _vector_2_or_3(value: Any) -> Any:
    if isinstance(value, (list, tuple)) and len(value) in (2, 3):
        return tuple(value) if len(value) == 3 else (*value, 0.0)
    got = f"{len(value)} items" if isinstance(value, (list, tuple)) else repr(value)
    raise PydanticCustomError(
        "vector", "must be a list of 2 or 3 numbers [dx, dy] or [dx, dy, dz], got {got}", {"got": got}
    )


def _interval(value: Any) -> Any:
    if isinstance(value, (list, tuple)) and len(value) == 2:
        return value
    got = f"{len(value)} items" if isinstance(value, (list, tuple)) else repr(value)
    raise PydanticCustomError(
        "vector", "must be a time interval [start, end] in seconds, got {got}", {"got": got}
    )


def _time_or_interval(value: Any) -> Any:
    if isinstance(value, (int, float)) and not isinstance(value, bool):
        return (value, value)
    return _interval(value)


Vec2 = Annotated[tuple[Real, Real], _vector(2, "[x, y]")]
Vec3 = Annotated[tuple[Real, Real, Real], _vector(3, "[x, y, z]")]
Waypoint = Annotated[tuple[Real, Real, Real, Real], _vector(4, "[t, x, y, z]")]
Rpy = Annotated[tuple[Real, Real, Real], _vector(3, "[roll, pitch, yaw] in degrees")]
Step = Annotated[tuple[Real, Real, Real], _vector(3, "[dx, dy, dyaw_deg]")]
Offset = Annotated[tuple[Real, Real, Real], BeforeValidator(_vector_2_or_3)]
Interval = Annotated[tuple[Time, Time], BeforeValidator(_interval)]
TimeOrInterval = Annotated[tuple[Time, Time], BeforeValidator(_time_or_interval)]


class _Model(BaseModel):
    model_config = ConfigDict(extra="forbid", frozen=True, allow_inf_nan=False, populate_by_name=True)


class Adjust(_Model):
    """How far the solver may move a touchdown: in time (± s) and in place (a radius, or a legal polygon)."""

    time: AdjustTime = Field(0.0, description="the event may move by ± this many seconds (at most 2)")
    radius: Annotated[float, Field(strict=True, ge=0.0, le=MAX_LENGTH_M)] | None = Field(
        None, description="the touchdown may move within this many meters (at most 1)"
    )
    region: tuple[Vec2, ...] | None = Field(
        None,
        max_length=64,
        description="a legal touchdown polygon [[x, y], ...] in the maneuver frame (instead of radius)",
    )

    @model_validator(mode="after")
    def _radius_or_region(self) -> Adjust:
        if self.radius is not None and self.region is not None:
            raise PydanticCustomError("adjust", "give either radius or region, not both")
        if self.region is not None and len(self.region) < 3:
            raise PydanticCustomError(
                "adjust",
                "region must be a polygon of at least 3 points [[x, y], ...], got {n}",
                {"n": len(self.region)},
            )
        return self


class LiftoffAdjust(_Model):
    """How far the solver may move a liftoff in time (± s)."""

    time: AdjustTime = Field(0.0, description="the liftoff may move by ± this many seconds (at most 2)")


class Liftoff(_Model):
    """A foot leaves the ground at time t."""

    t: Time = Field(description="time, s")
    leg: LegName
    type: Literal["liftoff"]
    adjust: LiftoffAdjust | None = None


class Touchdown(_Model):
    """A foot lands at time t: at a point, at an offset from where it lifted off, or (neither) where it lifted off."""

    t: Time = Field(description="time, s")
    leg: LegName
    type: Literal["touchdown"]
    at: Vec3 | None = Field(None, description="contact point [x, y, z] in the maneuver frame, m")
    offset: Offset | None = Field(
        None, description="[dx, dy] or [dx, dy, dz] from where the foot lifted off, maneuver frame, m"
    )
    normal: Vec3 = Field(
        (0.0, 0.0, 1.0), description="contact normal (need not be vertical, must not point down)"
    )
    adjust: Adjust | None = None
    waypoints: tuple[Waypoint, ...] | None = Field(
        None,
        max_length=32,
        description="points [t, x, y, z] (s; maneuver frame, m) the swinging foot passes through on its way, "
        "pausing at each: a wave, a reach, a gesture",
    )

    @model_validator(mode="after")
    def _at_or_offset(self) -> Touchdown:
        if self.at is not None and self.offset is not None:
            raise PydanticCustomError("touchdown", "give either at or offset, not both")
        return self


Event = Annotated[Liftoff | Touchdown, Field(discriminator="type")]


class Gait(_Model):
    """A periodic segment [from, to) expanded into liftoff/touchdown events, each leg stepping once per cycle."""

    gait: GaitName
    from_: Time = Field(alias="from", description="start time, s")
    to: Time = Field(description="end time, s (every swing lands by then)")
    cycle: Annotated[float, Field(strict=True, ge=0.1, le=10.0)] = Field(
        description="cycle period, s (0.1 to 10: faster than 0.1 s no leg can swing, slower is not a gait)"
    )
    duty: Annotated[float, Field(strict=True, gt=0.0, lt=1.0)] = Field(
        description="fraction of a cycle each foot is on the ground"
    )
    step: Step = Field((0.0, 0.0, 0.0), description="per cycle: dx, dy in the body frame (m), dyaw (degrees)")
    height: Length | None = Field(None, description="swing apex height above the line liftoff→touchdown, m")
    adjust: Adjust | None = Field(None, description="adjust window given to every touchdown of the segment")


class Keyframe(_Model):
    """A body target at time t with an importance weight; rpy = roll, pitch, yaw in degrees (pitch > 0: nose down)."""

    t: Time = Field(description="time, s")
    position: Vec3 = Field(description="body center [x, y, z] in the maneuver frame, m")
    rpy: Rpy = Field((0.0, 0.0, 0.0), description="roll, pitch, yaw, degrees, right-handed about x, y, z")
    weight: Weight = Field(1.0, description="importance of reaching this pose (0 to 1000)")


class Weights(_Model):
    """Cost weights of the planner's named terms (each 0 to 1000); the same names appear in the studio and the logs."""

    force: Weight = Field(1.0e-4, description="contact force magnitude")
    pose: Weight = Field(1.0, description="body pose tracking of the keyframes")
    touchdown_time: Weight = Field(1.0, description="deviation from the nominal touchdown times")
    touchdown_position: Weight = Field(10.0, description="deviation from the nominal touchdown positions")
    hip_over_foot: Weight = Field(0.1, description="hips kept above their feet")


class MaximizeHeight(_Model):
    """Custom cost: the body as high as possible during the interval t = [start, end] (a jump)."""

    type: Literal["maximize_height"]
    t: Interval
    weight: Weight = 1.0


class Lean(_Model):
    """Custom cost: lean the body as far as possible toward `direction` [x, y] at time t (or over [start, end])."""

    type: Literal["lean"]
    t: TimeOrInterval
    direction: Vec2
    weight: Weight = 1.0


class MinimizeTorque(_Model):
    """Custom cost: small joint torques during t = [start, end] (the whole maneuver when omitted)."""

    type: Literal["minimize_torque"]
    t: Interval | None = None
    weight: Weight = 1.0


Objective = Annotated[MaximizeHeight | Lean | MinimizeTorque, Field(discriminator="type")]


def _tracks(value: Any) -> Any:
    if isinstance(value, (list, tuple)) and len(set(map(str, value))) != len(value):
        raise PydanticCustomError("tracks", "lists a track twice: {value}", {"value": list(value)})
    if isinstance(value, (list, tuple)) and not value:
        raise PydanticCustomError("tracks", "must name at least one of legs, body")
    return value


class Hint(_Model):
    """A passive maneuver (tracks [body] only) played beside this one from time t: its body keyframes replace this
    maneuver's body targets over their span (both drive the body), and it is ignored if this one does not drive
    the body."""

    maneuver: str = Field(
        pattern=NAME_PATTERN, max_length=64, description="library name of a passive maneuver"
    )
    t: Time = Field(0.0, description="when it starts, s")


MIN_BPM, MAX_BPM = 30.0, 360.0  # tempos a maneuver can keep (the studio's beat finder reports 60 to 180)


class Music(_Model):
    """The music a maneuver is danced to: its tempo and where its first beat falls on the maneuver's clock (the
    studio shows the beat grid and snaps to it); the audio file itself is not part of the maneuver."""

    bpm: Annotated[float, Field(strict=True, ge=MIN_BPM, le=MAX_BPM)] = Field(
        description="tempo, beats per minute"
    )
    offset: Time = Field(0.0, description="time of the first beat on the maneuver's clock, s")
    file: str | None = Field(
        None, max_length=200, description="the audio file's name, for the user (not read)"
    )


class Maneuver(_Model):
    """A maneuver: sparse events, gait segments, body keyframes, cost weights and custom objectives."""

    model_config = ConfigDict(title="footfall maneuver (footfall/maneuver@1)")

    format: Literal["footfall/maneuver@1"] = Field(description="always footfall/maneuver@1")
    name: str = Field(pattern=NAME_PATTERN, max_length=64, description="lowercase letters, digits, dashes")
    title: str | None = Field(None, max_length=200)
    description: str = Field("", max_length=10_000)
    duration: Annotated[float, Field(strict=True, gt=0.0, le=MAX_DURATION_S)] = Field(
        description="total time, s"
    )
    start: Literal["stand"] = Field("stand", description="entry state")
    tracks: Annotated[tuple[TrackName, ...], BeforeValidator(_tracks)] = Field(
        ("legs", "body"), description="the tracks it drives; [body] only is a passive hint"
    )
    friction: Annotated[float, Field(strict=True, gt=0.0, le=3.0)] = Field(
        0.6, description="friction coefficient assumed at contacts"
    )
    events: tuple[Event, ...] = ()
    gaits: tuple[Gait, ...] = ()
    body: tuple[Keyframe, ...] = ()
    weights: Weights = Field(default_factory=lambda: Weights.model_validate({}))
    objectives: tuple[Objective, ...] = ()
    hints: tuple[Hint, ...] = Field((), max_length=16, description="passive maneuvers played beside this one")
    music: Music | None = Field(
        None, description="optional: the tempo and first beat of the music it is set to"
    )


def maneuver_json_schema() -> dict[str, Any]:
    """Returns the JSON Schema (draft 2020-12) of a maneuver file, with the aliases used in files (`from`)."""
    schema = Maneuver.model_json_schema(by_alias=True, mode="validation")
    return {
        "$schema": "https://json-schema.org/draft/2020-12/schema",
        "$id": "urn:footfall:maneuver@1",
        **schema,
    }
