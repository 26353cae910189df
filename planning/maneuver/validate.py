"""Checking a maneuver without simulating it: failures (blocking) and warnings (fixable), each with a field path.

Every rule is a small function `check_<name>(ctx) -> Iterable[Problem]`, collected in RULES; a rule sees the parsed
maneuver, the robot, and (when the events are consistent enough to build one) the expanded schedule and the body
reference. All rules run, so a file's problems come back all at once.
"""

from __future__ import annotations

import dataclasses
import math
import re
import threading
from collections import OrderedDict
from collections.abc import Callable, Iterable, Iterator
from dataclasses import dataclass, field, replace
from functools import cached_property, lru_cache
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
from pydantic import ValidationError

from planning.maneuver.body import BodyReference, rotation_from_rpy
from planning.maneuver.expand import (
    LEG_INDEX,
    LEGS,
    MAX_EVENTS,
    Schedule,
    build_schedule,
    count_events,
    gait_cycles,
)
from planning.maneuver.load import parse_maneuver, read_source
from planning.maneuver.problems import ManeuverError, Problem, with_lines
from planning.maneuver.scale import scale_to_robot
from planning.maneuver.spec import FORMAT, Liftoff, Maneuver, MaximizeHeight, Touchdown
from planning.maneuver.torque import check_keyframe_torque

if TYPE_CHECKING:
    from planning.robot import RobotModel


@dataclass(frozen=True)
class Params:
    """Thresholds of the warnings."""

    reach_warn_fraction: float = 0.90  # touchdown farther than this share of the max leg length from its hip
    min_swing_s: float = 0.15  # shorter swings rarely clear the ground, s
    min_support_feet: int = 3  # fewer feet down without a dynamic intent is statically unstable
    path_check_dt_s: float = 0.1  # sampling step of the body path reach check, s
    max_body_speed_mps: float = 1.0  # faster keyframe-to-keyframe body motion is unlikely to be tracked, m/s
    max_body_rate_rps: float = 3.0  # same for the angular rate, rad/s
    start_pose_tol_m: float = 0.01  # a keyframe at t = 0 farther than this from the start pose jumps, m
    start_pose_tol_rad: float = math.radians(1.0)
    min_keyframe_gap_s: float = 0.01  # closer keyframes ask for a jump, s


@dataclass(frozen=True)
class ValidationResult:
    """Outcome of validate_maneuver: ok when there is no failure; the parsed pieces when they could be built."""

    ok: bool
    warnings: list[Problem]
    failures: list[Problem]
    maneuver: Maneuver | None = None
    schedule: Schedule | None = None
    body: BodyReference | None = None
    # the physics check's section (planning.maneuver.physics), when it ran
    physics: dict[str, Any] | None = None

    def to_dict(self) -> dict[str, Any]:
        """Returns the REST answer: {"ok", "warnings", "failures"} with problems as dicts (and "physics", the
        physics check's measurements, when it ran)."""
        out: dict[str, Any] = {
            "ok": self.ok,
            "warnings": [p.to_dict() for p in self.warnings],
            "failures": [p.to_dict() for p in self.failures],
        }
        if self.physics is not None:
            out["physics"] = self.physics
        return out

    def raise_for_failures(self) -> Maneuver:
        """Returns the maneuver when there is no failure; raises ManeuverError with the failures otherwise."""
        if not self.ok or self.maneuver is None:
            raise ManeuverError(self.failures)
        return self.maneuver


@dataclass
class Context:
    """What the rules look at; the derived pieces are computed once, on first use."""

    maneuver: Maneuver
    robot: RobotModel
    params: Params = field(default_factory=Params)

    @cached_property
    def schedule_or_problems(self) -> Schedule | list[Problem]:
        try:
            return build_schedule(self.maneuver, self.robot)
        except ManeuverError as e:
            return e.problems

    @property
    def schedule(self) -> Schedule | None:
        s = self.schedule_or_problems
        return s if isinstance(s, Schedule) else None

    @cached_property
    def body(self) -> BodyReference | None:
        try:
            if self.maneuver.body:
                return BodyReference.from_maneuver(self.maneuver, self.robot)
            s = self.schedule
            return None if s is None else BodyReference.from_maneuver(self.maneuver, self.robot, s)
        except (ManeuverError, ValueError):
            return None

    incomplete_legs: frozenset[str] = frozenset()  # legs with an event dropped for a shape error: not paired

    @cached_property
    def time_order(self) -> list[int]:
        """Returns the indices of the explicit events in time order (stable: listing order at equal times)."""
        return sorted(range(len(self.maneuver.events)), key=lambda i: self.maneuver.events[i].t)

    @cached_property
    def explicit_swings(self) -> list[tuple[int, int, int]]:
        """Returns (leg, liftoff index, touchdown index) of the explicit events, paired per leg in time order."""
        open_: dict[str, int] = {}
        out = []
        for i in self.time_order:
            ev = self.maneuver.events[i]
            if isinstance(ev, Liftoff):
                open_.setdefault(ev.leg, i)
            elif ev.leg in open_:
                out.append((LEG_INDEX[ev.leg], open_.pop(ev.leg), i))
        return out

    def foot_center(self, contact: np.ndarray, normal: np.ndarray) -> np.ndarray:
        return contact + float(self.robot.foot_radius_m) * normal


Rule = Callable[[Context], Iterable[Problem]]


def _fail(path: str, message: str) -> Problem:
    return Problem(path, message, "failure")


def _warn(path: str, message: str) -> Problem:
    return Problem(path, message, "warning")


def _s(t: float) -> str:
    return f"{t:g} s"


# ---- events ----------------------------------------------------------------------------------------------------
def check_events_within_duration(ctx: Context) -> Iterator[Problem]:
    """Failure: an event after the end of the maneuver."""
    d = ctx.maneuver.duration
    for i, ev in enumerate(ctx.maneuver.events):
        if ev.t > d:
            yield _fail(
                f"events[{i}].t",
                f"{ev.type} of {ev.leg} at {_s(ev.t)} is after the end of the maneuver (duration {_s(d)})",
            )


def check_liftoff_touchdown_pairs(ctx: Context) -> Iterator[Problem]:
    """Failure: per leg and in time order (events may be listed in any order), liftoff and touchdown alternate."""
    events = ctx.maneuver.events
    open_: dict[str, tuple[int, float]] = {}
    answered: set[int] = set()  # liftoffs already named by a touchdown listed before them in time
    for i in ctx.time_order:
        ev = events[i]
        if ev.leg in ctx.incomplete_legs or i in answered:
            continue
        if isinstance(ev, Liftoff):
            if ev.leg in open_:
                k, t0 = open_[ev.leg]
                yield _fail(
                    f"events[{i}]",
                    f"liftoff of {ev.leg} at {_s(ev.t)} while it is already in the air "
                    f"(it lifted off at {_s(t0)}, events[{k}]); add its touchdown in between",
                )
                continue
            open_[ev.leg] = (i, ev.t)
            continue
        if ev.leg not in open_:
            # listed after its liftoff but earlier in time: say so plainly
            lo = next((k for k in range(i - 1, -1, -1) if events[k].leg == ev.leg), None)
            if lo is not None and isinstance(events[lo], Liftoff) and events[lo].t > ev.t:
                answered.add(lo)
                yield _fail(
                    f"events[{i}].t",
                    f"touchdown of {ev.leg} at {_s(ev.t)} comes before its liftoff at {_s(events[lo].t)}",
                )
                continue
            yield _fail(
                f"events[{i}]",
                f"touchdown of {ev.leg} at {_s(ev.t)} while it is on the ground; "
                f"add a liftoff of {ev.leg} before it",
            )
            continue
        k, t0 = open_.pop(ev.leg)
        if ev.t == t0:
            yield _fail(
                f"events[{i}].t", f"touchdown of {ev.leg} at {_s(ev.t)} is at the same time as its liftoff"
            )
    for leg, (k, t0) in open_.items():
        yield _fail(
            f"events[{k}]",
            f"{leg} lifts off at {_s(t0)} and never touches down; add a touchdown before "
            f"the end ({_s(ctx.maneuver.duration)})",
        )


def check_touchdown_normals(ctx: Context) -> Iterator[Problem]:
    """Failure: a zero contact normal, or one pointing down (a foot cannot push on a ceiling)."""
    for i, ev in enumerate(ctx.maneuver.events):
        if not isinstance(ev, Touchdown):
            continue
        n = np.asarray(ev.normal)
        norm = float(np.linalg.norm(n))
        if norm < 1e-9:
            yield _fail(f"events[{i}].normal", "must not be the zero vector")
        elif n[2] / norm < -1e-9:
            yield _fail(
                f"events[{i}].normal", f"{list(ev.normal)} points downward: the foot would push on a ceiling"
            )


def _segments_cross(a: np.ndarray, b: np.ndarray, c: np.ndarray, d: np.ndarray) -> bool:
    def orient(p: np.ndarray, q: np.ndarray, r: np.ndarray) -> float:
        return float((q[0] - p[0]) * (r[1] - p[1]) - (q[1] - p[1]) * (r[0] - p[0]))

    return orient(a, b, c) * orient(a, b, d) < 0 and orient(c, d, a) * orient(c, d, b) < 0


def polygon_problem(poly: np.ndarray) -> str | None:
    """Returns why a polygon (K,2) is not a usable region (zero area, edges crossing), or None."""
    k = len(poly)
    for i in range(k):
        for j in range(i + 2, k):
            if i == 0 and j == k - 1:
                continue
            if _segments_cross(poly[i], poly[(i + 1) % k], poly[j], poly[(j + 1) % k]):
                return f"edges {i}–{i + 1} and {j}–{(j + 1) % k} cross; list the points around the polygon in order"
    x, y = poly[:, 0], poly[:, 1]
    area = 0.5 * abs(float(np.dot(x, np.roll(y, -1)) - np.dot(y, np.roll(x, -1))))
    if area < 1e-6:
        return "has no area (its points lie on a line or coincide)"
    return None


def point_in_polygon(p: np.ndarray, poly: np.ndarray) -> bool:
    """Returns whether the point p (2,) lies inside the polygon (K,2) (even-odd rule; the boundary counts in)."""
    inside = False
    k = len(poly)
    for i in range(k):
        a, b = poly[i], poly[(i - 1) % k]
        if (a[1] > p[1]) != (b[1] > p[1]):
            x = a[0] + (p[1] - a[1]) * (b[0] - a[0]) / (b[1] - a[1])
            if abs(x - p[0]) < 1e-9:
                return True
            inside ^= p[0] < x
    return inside


def check_adjust_regions(ctx: Context) -> Iterator[Problem]:
    """Failure: a region polygon that crosses itself or has no area; warning: a target outside it."""
    for path, adjust in [
        (f"events[{i}]", getattr(e, "adjust", None)) for i, e in enumerate(ctx.maneuver.events)
    ] + [(f"gaits[{j}]", g.adjust) for j, g in enumerate(ctx.maneuver.gaits)]:
        region = getattr(adjust, "region", None)
        if region is None:
            continue
        why = polygon_problem(np.array(region, dtype=float))
        if why:
            yield _fail(f"{path}.adjust.region", why)
        elif path.startswith("gaits"):
            yield _warn(
                f"{path}.adjust.region",
                "one region in the maneuver frame applies to every touchdown of the "
                "gait, for every leg; a radius is usually what is meant",
            )
    s = ctx.schedule
    if s is None:
        return
    for sw in s.all_swings():
        r = sw.adjust.region_xy
        if r is not None and sw.touchdown_path.startswith("events") and polygon_problem(r) is None:
            if not point_in_polygon(sw.p_touchdown[:2], r):
                yield _warn(
                    f"{sw.touchdown_path}.adjust.region",
                    f"the touchdown target "
                    f"{np.round(sw.p_touchdown, 3).tolist()} lies outside its region; the planner will move it",
                )


def check_adjust_windows_overlap(ctx: Context) -> Iterator[Problem]:
    """Failure: consecutive events of one leg whose adjust windows overlap."""
    s = ctx.schedule
    if s is None:
        return
    for leg, swings in enumerate(s.swings):
        seq: list[tuple[float, float, str, str]] = []  # (t, ±s, kind, path)
        for sw in swings:
            seq.append((sw.t_liftoff, sw.liftoff_adjust_s, "liftoff", sw.liftoff_path))
            seq.append((sw.t_touchdown, sw.adjust.time_s, "touchdown", sw.touchdown_path))
        reported: set[str] = set()
        for (t0, a0, k0, p0), (t1, a1, k1, p1) in zip(seq, seq[1:], strict=False):
            if (a0 > 0 or a1 > 0) and t0 + a0 > t1 - a1 and p1 not in reported:
                reported.add(p1)
                path = p1 if a1 > 0 else p0
                yield _fail(
                    f"{path}.adjust.time",
                    f"the adjust windows of {LEGS[leg]}'s {k0} at {_s(t0)} (±{_s(a0)}) "
                    f"and {k1} at {_s(t1)} (±{_s(a1)}) overlap; the planner could swap them",
                )


# ---- gaits -----------------------------------------------------------------------------------------------------
def check_gait_spans(ctx: Context) -> Iterator[Problem]:
    """Failure: a gait that ends before it starts, after the maneuver, or holds no whole cycle."""
    d = ctx.maneuver.duration
    for j, g in enumerate(ctx.maneuver.gaits):
        if g.from_ >= g.to:
            yield _fail(
                f"gaits[{j}].to", f"the segment ends at {_s(g.to)}, not after its start at {_s(g.from_)}"
            )
            continue
        if g.to > d:
            yield _fail(f"gaits[{j}].to", f"{_s(g.to)} is after the end of the maneuver (duration {_s(d)})")
        n = gait_cycles(g)
        span = g.to - g.from_
        if n == 0:
            yield _fail(
                f"gaits[{j}].cycle",
                f"a {_s(g.cycle)} cycle does not fit in the {_s(span)} segment; no step would be taken",
            )
        elif span - n * g.cycle > 1e-6:
            yield _warn(
                f"gaits[{j}].to",
                f"the segment lasts {_s(round(span, 6))}, not a whole number of "
                f"{_s(g.cycle)} cycles; its last {_s(round(span - n * g.cycle, 6))} take no step",
            )


def check_gaits_overlap(ctx: Context) -> Iterator[Problem]:
    """Failure: two gait segments at the same time."""
    order = sorted(range(len(ctx.maneuver.gaits)), key=lambda j: ctx.maneuver.gaits[j].from_)
    for a, b in zip(order, order[1:], strict=False):
        ga, gb = ctx.maneuver.gaits[a], ctx.maneuver.gaits[b]
        if gb.from_ < ga.to:
            yield _fail(
                f"gaits[{b}].from",
                f"the {gb.gait} starting at {_s(gb.from_)} overlaps gaits[{a}] "
                f"({ga.gait} {_s(ga.from_)}–{_s(ga.to)})",
            )


def check_gait_event_clash(ctx: Context) -> Iterator[Problem]:
    """Failure: an explicit event (or swing) inside a gait segment, which drives every leg."""
    events = ctx.maneuver.events
    for j, g in enumerate(ctx.maneuver.gaits):
        if g.from_ >= g.to:
            continue
        what = f"gaits[{j}] ({g.gait} {_s(g.from_)}–{_s(g.to)}), which moves every leg then"
        for i, ev in enumerate(events):
            if g.from_ < ev.t < g.to:
                yield _fail(f"events[{i}].t", f"{ev.type} of {ev.leg} at {_s(ev.t)} falls inside {what}")
        for _leg, lo, td in ctx.explicit_swings:
            t0, t1 = events[lo].t, events[td].t
            if t0 <= g.from_ and t1 >= g.to and t0 < t1:
                yield _fail(
                    f"events[{lo}]",
                    f"{events[lo].leg} is in the air from {_s(t0)} to {_s(t1)}, across {what}",
                )


def check_event_count(ctx: Context) -> Iterator[Problem]:
    """Failure: more than MAX_EVENTS events after gait expansion."""
    n = count_events(ctx.maneuver)
    if n > MAX_EVENTS:
        listed = len(ctx.maneuver.events)
        path = "gaits" if n - listed > listed else "events"
        yield _fail(
            path,
            f"the maneuver has {n} events after gait expansion ({listed} listed, {n - listed} from "
            f"gaits); at most {MAX_EVENTS} are allowed",
        )


# ---- body keyframes --------------------------------------------------------------------------------------------
def check_keyframe_times(ctx: Context) -> Iterator[Problem]:
    """Failure: keyframes out of order, too close together, or after the end."""
    body, d = ctx.maneuver.body, ctx.maneuver.duration
    for i, k in enumerate(body):
        t_prev = body[i - 1].t if i > 0 else 0.0
        if (i > 0 or k.t > 0.0) and t_prev < k.t < t_prev + ctx.params.min_keyframe_gap_s:
            yield _fail(
                f"body[{i}].t",
                f"keyframe at {_s(k.t)} comes only {_s(k.t - t_prev)} after the "
                f"{'previous keyframe' if i > 0 else 'start'}; keep keyframes at least "
                f"{_s(ctx.params.min_keyframe_gap_s)} apart",
            )
        if i > 0 and k.t <= body[i - 1].t:
            yield _fail(
                f"body[{i}].t",
                f"keyframe at {_s(k.t)} does not come after body[{i - 1}] at "
                f"{_s(body[i - 1].t)}; list keyframes in time order, one per time",
            )
        if k.t > d:
            yield _fail(
                f"body[{i}].t", f"keyframe at {_s(k.t)} is after the end of the maneuver (duration {_s(d)})"
            )


def check_keyframe_weights(ctx: Context) -> Iterator[Problem]:
    """Warning: a keyframe with weight 0."""
    for i, k in enumerate(ctx.maneuver.body):
        if k.weight == 0.0:
            yield _warn(f"body[{i}].weight", f"is 0: the keyframe at {_s(k.t)} will be ignored")


def _unreachable(ctx: Context, s: Schedule, t: float, p_world_body: np.ndarray, rpy: np.ndarray) -> list[str]:
    """Returns the reach errors of the stance feet at time t with the body at the given pose."""
    R = rotation_from_rpy(rpy)
    errors = []
    for leg in range(4):
        if not s.in_stance(leg, t):
            continue
        p_world_foot = ctx.foot_center(s.foot_position(leg, t), s.foot_normal(leg, t))
        try:
            ctx.robot.ik_leg(leg, R.T @ (p_world_foot - p_world_body))
        except ValueError as e:  # ReachError is a ValueError
            errors.append(str(e))
    return errors


def check_keyframe_reach(ctx: Context) -> Iterator[Problem]:
    """Failure: a keyframe pose from which a stance foot is out of the leg's reach."""
    s = ctx.schedule
    if s is None:
        return
    for i, k in enumerate(ctx.maneuver.body):
        for err in _unreachable(ctx, s, k.t, np.array(k.position), np.radians(k.rpy)):
            leg = err.split(":", 1)[0]
            yield _fail(f"body[{i}]", f"keyframe at {_s(k.t)} puts the {leg} foot out of reach — {err}")


def check_body_path_reach(ctx: Context) -> Iterator[Problem]:
    """Warning: the body path between keyframes takes a stance foot out of reach."""
    s, body = ctx.schedule, ctx.body
    if s is None or body is None or not body.from_keyframes:
        return
    key_times = {k.t for k in ctx.maneuver.body}
    seen: set[str] = set()
    for t in np.arange(0.0, ctx.maneuver.duration + 1e-9, ctx.params.path_check_dt_s):
        if any(abs(t - tk) < 1e-6 for tk in key_times):
            continue
        p, _, rpy, _ = body.sample(float(t))
        for err in _unreachable(ctx, s, float(t), p, rpy):
            leg = err.split(":", 1)[0]
            if leg not in seen:
                seen.add(leg)
                yield _warn(
                    "body",
                    f"between keyframes, at {_s(round(float(t), 3))}, the body path puts the {leg} "
                    f"foot out of reach — {err}",
                )


def check_body_speed(ctx: Context) -> Iterator[Problem]:
    """Warning: keyframes so close in time that the body must move or turn very fast."""
    body, P = ctx.body, ctx.params
    if body is None or not body.from_keyframes:
        return
    keys = ctx.maneuver.body
    for i in range(len(keys)):
        t0 = keys[i - 1].t if i > 0 else 0.0
        if keys[i].t < t0 + P.min_keyframe_gap_s:  # reported by check_keyframe_times
            continue
        ts = np.linspace(t0, keys[i].t, 12)[1:-1]
        v = max(float(np.linalg.norm(body.sample(float(t))[1])) for t in ts)
        w = max(float(np.linalg.norm(body.sample(float(t))[3])) for t in ts)
        if v > P.max_body_speed_mps:
            yield _warn(
                f"body[{i}].t",
                f"reaching this keyframe moves the body at up to {v:.2f} m/s; "
                f"give it more time (above {P.max_body_speed_mps:g} m/s it is unlikely to be tracked)",
            )
        if w > P.max_body_rate_rps:
            yield _warn(
                f"body[{i}].t",
                f"reaching this keyframe turns the body at up to {w:.1f} rad/s; "
                f"give it more time (above {P.max_body_rate_rps:g} rad/s it is unlikely to be tracked)",
            )


def check_start_keyframe(ctx: Context) -> Iterator[Problem]:
    """Warning: a keyframe at t = 0 away from the standing start pose."""
    body, P = ctx.maneuver.body, ctx.params
    if not body or body[0].t > 0.0:
        return
    k = body[0]
    dp = np.linalg.norm(np.array(k.position) - [0.0, 0.0, ctx.robot.standing_height_m])
    da = float(np.max(np.abs(np.radians(k.rpy))))
    if dp > P.start_pose_tol_m or da > P.start_pose_tol_rad:
        yield _warn(
            "body[0]",
            "keyframe at 0 s differs from the standing start pose "
            f"[0, 0, {ctx.robot.standing_height_m:g}] level; the robot cannot be there at once, give it time",
        )


# ---- feet ------------------------------------------------------------------------------------------------------
def check_touchdown_reach(ctx: Context) -> Iterator[Problem]:
    """Failure: a touchdown out of reach of its hip (body at the reference); warning: near it."""
    s, body = ctx.schedule, ctx.body
    if s is None or body is None:
        return
    reach = float(ctx.robot.max_leg_length_m)
    p_body_hip = np.asarray(ctx.robot.p_body_hip, dtype=float)
    worst: dict[str, tuple[float, str]] = {}
    adjustable: set[str] = set()
    for sw in s.all_swings():
        if sw.adjust.time_s > 0.0 or sw.adjust.radius_m or sw.adjust.region_xy is not None:
            adjustable.add(sw.touchdown_path)
        p, _, rpy, _ = body.sample(sw.t_touchdown)
        hip = p + rotation_from_rpy(rpy) @ p_body_hip[sw.leg]
        dist = float(np.linalg.norm(ctx.foot_center(sw.p_touchdown, sw.normal) - hip))
        ratio = dist / reach
        if ratio > ctx.params.reach_warn_fraction and ratio > worst.get(sw.touchdown_path, (0.0, ""))[0]:
            worst[sw.touchdown_path] = (
                ratio,
                f"touchdown of {LEGS[sw.leg]} at {_s(round(sw.t_touchdown, 6))} is "
                f"{dist:.2f} m from its hip ({ratio:.0%} of the leg's {reach:.2f} m reach)",
            )
    for path, (ratio, msg) in worst.items():
        if ratio > 1.0 and path in adjustable:
            # the solver may move it (time or place) to where the body can be: the dry solve decides
            yield _warn(
                path, f"{msg}: out of reach at its nominal time and place; relies on its adjust window"
            )
        elif ratio > 1.0:
            yield _fail(path, f"{msg}: out of reach with the body where the maneuver puts it")
        else:
            yield _warn(path, f"{msg}: near the edge of reach")


def check_swing_durations(ctx: Context) -> Iterator[Problem]:
    """Warning: swings shorter than Params.min_swing_s."""
    s = ctx.schedule
    if s is None:
        return
    reported: set[str] = set()
    for sw in s.all_swings():
        if 0.0 < sw.duration_s < ctx.params.min_swing_s and sw.touchdown_path not in reported:
            reported.add(sw.touchdown_path)
            yield _warn(
                sw.touchdown_path,
                f"{LEGS[sw.leg]} swings for only {_s(round(sw.duration_s, 6))} "
                f"({_s(round(sw.t_liftoff, 6))} → {_s(round(sw.t_touchdown, 6))}); below "
                f"{_s(ctx.params.min_swing_s)} the foot may not clear the ground",
            )


def check_waypoints(ctx: Context) -> Iterator[Problem]:
    """Failure: swing waypoints out of time order, outside their swing, or out of the leg's reach."""
    s = ctx.schedule
    if s is None:
        return
    for sw in s.all_swings():
        if sw.waypoints is None:
            continue
        t_prev = sw.t_liftoff
        for k, (t, x, y, z) in enumerate(sw.waypoints):
            path = f"{sw.touchdown_path}.waypoints[{k}]"
            if not (t_prev < t < sw.t_touchdown):
                yield _fail(
                    path,
                    f"waypoint at {_s(t)} must come after {_s(round(t_prev, 6))} and before the touchdown of "
                    f"{LEGS[sw.leg]} at {_s(sw.t_touchdown)}",
                )
                break
            t_prev = t
            body = ctx.body
            if body is None or ctx.robot is None:
                continue
            p_body, _, rpy, _ = body.sample(float(t))
            R = rotation_from_rpy(rpy)
            foot = ctx.foot_center(np.array([x, y, z]), np.array([0.0, 0.0, 1.0]))
            try:
                ctx.robot.ik_leg(sw.leg, R.T @ (foot - p_body))
            except ValueError as e:  # ReachError
                yield _fail(path, f"the foot cannot reach it: {e}")


def check_hints(ctx: Context) -> Iterator[Problem]:
    """Failure: a hint that is not a passive library maneuver or runs past the end; warning: one that is ignored."""
    m = ctx.maneuver
    if not m.hints or ctx.robot is None:
        return
    from planning.maneuver.hints import load_hints

    try:
        load_hints(m, ctx.robot)
    except ManeuverError as e:
        for p in e.problems:
            yield _fail(p.path, p.message)
        return
    if "body" not in m.tracks:
        yield _warn("hints", "this maneuver does not drive the body, so its hints are ignored")


def _dynamic_windows(m: Maneuver) -> list[tuple[float, float]]:
    """Returns the time windows where the maneuver says it means to be dynamic: gaits and jumps."""
    out = [(g.from_, g.to) for g in m.gaits]
    out += [(o.t[0], o.t[1]) for o in m.objectives if isinstance(o, MaximizeHeight)]
    return out


def check_support_feet(ctx: Context) -> Iterator[Problem]:
    """Warning: fewer than three feet down outside a gait or a jump."""
    s = ctx.schedule
    if s is None:
        return
    windows = _dynamic_windows(ctx.maneuver)
    events = s.events()
    first_liftoff: dict[float, str] = {}
    for e in events:
        if e.type == "liftoff":
            first_liftoff.setdefault(e.t, e.path)
    times = sorted({0.0, *(e.t for e in events)})
    low_from: float | None = None
    low_legs: set[str] = set()
    low_path = ""
    spans: list[tuple[float, float, set[str], str]] = []
    for a, b in zip(times, [*times[1:], ctx.maneuver.duration], strict=False):
        if b <= a:
            continue
        mid = 0.5 * (a + b)
        mask = s.stance_mask(mid)
        covered = any(w0 <= a and b <= w1 for w0, w1 in windows)
        if int(mask.sum()) < ctx.params.min_support_feet and not covered:
            if low_from is None:
                low_from, low_path = a, first_liftoff.get(a, "")
            low_legs |= {LEGS[i] for i in range(4) if not mask[i]}
            continue
        if low_from is not None:
            spans.append((low_from, a, low_legs, low_path))
            low_from, low_legs = None, set()
    if low_from is not None:
        spans.append((low_from, ctx.maneuver.duration, low_legs, low_path))
    for a, b, legs, path in spans:
        n_air = len(legs)
        yield _warn(
            path or "events",
            f"from {_s(round(a, 6))} to {_s(round(b, 6))} {4 - n_air if n_air < 4 else 'no'} "
            f"feet may be on the ground ({', '.join(sorted(legs, key=LEGS.index))} in the air): statically "
            "unstable; fine for a dynamic move (a gait or a maximize_height objective says so)",
        )


# ---- the rest --------------------------------------------------------------------------------------------------
def check_tracks(ctx: Context) -> Iterator[Problem]:
    """Warning: events without the legs track, keyframes without the body track."""
    m = ctx.maneuver
    if "legs" not in m.tracks and (m.events or m.gaits):
        yield _warn(
            "tracks", "does not include legs, yet the maneuver has events or gaits: it is only a hint"
        )
    if "body" not in m.tracks and m.body:
        yield _warn(
            "tracks", "does not include body, yet the maneuver has body keyframes: they are only a hint"
        )


def check_objectives(ctx: Context) -> Iterator[Problem]:
    """Failure: an empty or late objective window, a zero lean direction."""
    d = ctx.maneuver.duration
    for i, o in enumerate(ctx.maneuver.objectives):
        if o.t is not None:
            a, b = o.t
            if b < a or (isinstance(o, MaximizeHeight) and b == a):
                yield _fail(f"objectives[{i}].t", f"the window [{a:g}, {b:g}] s is empty; give [start, end]")
            elif b > d:
                yield _fail(
                    f"objectives[{i}].t",
                    f"the window ends at {_s(b)}, after the end of the maneuver (duration {_s(d)})",
                )
        if getattr(o, "direction", None) is not None and float(np.hypot(*o.direction)) < 1e-9:  # type: ignore[union-attr]
            yield _fail(f"objectives[{i}].direction", "must not be the zero vector")


RULES: list[Rule] = [
    check_events_within_duration,
    check_liftoff_touchdown_pairs,
    check_touchdown_normals,
    check_adjust_regions,
    check_adjust_windows_overlap,
    check_gait_spans,
    check_gaits_overlap,
    check_gait_event_clash,
    check_event_count,
    check_keyframe_times,
    check_keyframe_weights,
    check_keyframe_reach,
    check_body_path_reach,
    check_body_speed,
    check_start_keyframe,
    check_touchdown_reach,
    check_swing_durations,
    check_waypoints,
    check_hints,
    check_support_feet,
    check_tracks,
    check_objectives,
    check_keyframe_torque,
]


def _run_rules(ctx: Context) -> list[Problem]:
    problems: list[Problem] = []
    for rule in RULES:
        try:
            problems.extend(rule(ctx))
        except Exception as e:  # a rule must never turn a user's file into a traceback
            problems.append(
                _fail("", f"could not run the check {rule.__name__.removeprefix('check_')}: {e!r}")
            )
    return problems


_LISTS = ("events", "body", "gaits", "objectives", "hints")
_ITEM = re.compile(r"\b(events|body|gaits|objectives|hints)\[(\d+)\]")
_REQUIRED_STAND_INS = {"format": FORMAT, "name": "partial"}  # required fields the rules do not look at


@dataclass(frozen=True)
class _Partial:
    """The well-formed rest of a document with shape errors, and where its list items came from."""

    maneuver: Maneuver
    kept: dict[str, list[int]]  # list name → original index of each kept item
    incomplete_legs: frozenset[str]

    def original(self, p: Problem) -> Problem:
        """Returns the problem with list indices (in its path and its message) as in the original document."""

        def back(m: re.Match[str]) -> str:
            kept = self.kept.get(m.group(1))
            i = int(m.group(2))
            return f"{m.group(1)}[{kept[i] if kept is not None and i < len(kept) else i}]"

        return replace(p, path=_ITEM.sub(back, p.path), message=_ITEM.sub(back, p.message))


def _without_bad_items(data: Any, shape: list[Problem]) -> _Partial | None:
    """Returns the document without the items (and optional fields) its shape problems are about, parsed; or
    None when what is wrong is needed by every rule (the duration, the document itself)."""
    if not isinstance(data, dict):
        return None
    doc = dict(data)
    bad_items: dict[str, set[int]] = {}
    for p in shape:
        m = re.match(r"^(events|body|gaits|objectives|hints)\[(\d+)\]", p.path)
        if m:
            bad_items.setdefault(m.group(1), set()).add(int(m.group(2)))
            continue
        root = re.split(r"[.\[]", p.path, maxsplit=1)[0]
        if root in ("", "duration") or root not in Maneuver.model_fields:
            return None
        if root in _REQUIRED_STAND_INS:
            doc[root] = _REQUIRED_STAND_INS[root]
        else:
            doc.pop(root, None)  # an optional field: its default stands in
    kept: dict[str, list[int]] = {}
    incomplete: set[str] = set()
    for key, bad in bad_items.items():
        items = doc.get(key)
        if not isinstance(items, list):
            return None
        kept[key] = [i for i in range(len(items)) if i not in bad]
        doc[key] = [items[i] for i in kept[key]]
        if key == "events":
            incomplete |= {str(items[i].get("leg")) for i in bad if isinstance(items[i], dict)}
    try:
        maneuver = Maneuver.model_validate(doc)
    except (ValidationError, RecursionError):
        return None
    return _Partial(maneuver, kept, frozenset(incomplete & set(LEGS)))


@lru_cache(maxsize=4)
def _default_robot(name: str = "spot") -> RobotModel:
    from planning.robot import load_robot

    return load_robot(name)


def validate_maneuver(
    source: Maneuver | dict[str, Any] | str | Path,
    robot: RobotModel | None = None,
    params: Params | None = None,
    dry_solve: bool = False,
) -> ValidationResult:
    """Returns the warnings and failures of a maneuver (object, dict, YAML text or file path) for a robot.

    Never raises for bad input: unreadable files, YAML syntax and shape errors come back as failures.
    `robot` defaults to the shipped Spot-class model. dry_solve: when the rules pass, also run the centroidal
    solver along the plan (planning.maneuver.drysolve): warnings where it moves a touchdown, failures where the
    problem is infeasible even with every adjustment.
    """
    lines: dict[str, int] | None = None
    data: Any = source
    try:
        if isinstance(source, (str, Path)):
            data, lines, name = read_source(source)
            maneuver = parse_maneuver(data, lines=lines, source=name)
        else:
            maneuver = parse_maneuver(source)
    except ManeuverError as e:
        shape = [p for p in e.problems if p.severity == "failure"]
        # the rules still check what is well formed: every problem of the file comes back in one pass
        partial = _without_bad_items(data, shape)
        if partial is None:
            return ValidationResult(False, [], shape)
        robot = robot if robot is not None else _default_robot()
        ctx = Context(scale_to_robot(partial.maneuver, robot), robot, params or Params(),
                      incomplete_legs=partial.incomplete_legs)  # fmt: skip
        found = with_lines([partial.original(p) for p in _run_rules(ctx)], lines)
        seen = {(p.path, p.message) for p in shape}
        more = [p for p in found if (p.path, p.message) not in seen]
        return ValidationResult(
            False,
            [p for p in more if p.severity == "warning"],
            shape + [p for p in more if p.severity == "failure"],
        )
    robot = robot if robot is not None else _default_robot()
    maneuver = scale_to_robot(maneuver, robot)  # lengths are the reference robot's (planning.maneuver.scale)
    ctx = Context(maneuver, robot, params or Params())
    problems = with_lines(_run_rules(ctx), lines)
    failures = [p for p in problems if p.severity == "failure"]
    if not failures and not isinstance(ctx.schedule_or_problems, Schedule):
        # the schedule does not build for a reason no rule names: report the builder's words
        failures = with_lines(ctx.schedule_or_problems, lines)
    warnings = [p for p in problems if p.severity == "warning"]
    if dry_solve and not failures and ctx.schedule is not None and ctx.body is not None:
        from planning.maneuver.drysolve import dry_solve as _dry_solve

        try:
            found = _dry_solve(maneuver, ctx.schedule, ctx.body, ctx.robot)
        except Exception as e:  # the solver must never turn a user's file into a traceback
            found = [_fail("", f"the dry solve could not run: {e!r}")]
        found = with_lines(found, lines)
        failures += [p for p in found if p.severity == "failure"]
        warnings += [p for p in found if p.severity == "warning"]
    ok = not failures
    return ValidationResult(ok, warnings, failures, maneuver, ctx.schedule, ctx.body)


# (id of the robot, the maneuver's content) → (the robot, the result); the robot is kept so its id is not reused
_CHECKED: OrderedDict[tuple[int, str], tuple[Any, ValidationResult]] = OrderedDict()
_CHECKED_LOCK = threading.Lock()
_CHECKED_MAX = 64


def check_maneuver(
    source: Maneuver | dict[str, Any] | str | Path, robot: RobotModel | None = None, *, dry_solve: bool = True
) -> ValidationResult:
    """The one validation of footfall: the shape, every rule, then the dry solve (the centroidal solver run along
    the plan). `footfall validate` and `run`, POST /maneuvers/validate, PUT /maneuvers/{name}, simulations,
    sessions and the studio all call this, so a maneuver is valid in one place exactly when it is in all.

    Never raises for bad input. The dry solve costs about 0.1 s of CPU per simulated second; results are kept
    for the last 64 maneuvers (by content, ignoring name, title and description), so validating, then saving,
    then running the same document solves once. dry_solve=False is `footfall validate --no-solve` only.
    """
    if not dry_solve or not isinstance(source, Maneuver):
        return validate_maneuver(source, robot, dry_solve=dry_solve)
    robot = robot if robot is not None else _default_robot()
    key = (id(robot), source.model_dump_json(exclude={"name", "title", "description"}))
    with _CHECKED_LOCK:
        entry = _CHECKED.get(key)
        if entry is not None:
            _CHECKED.move_to_end(key)
    if entry is not None and entry[0] is robot and entry[1].maneuver is not None:
        return dataclasses.replace(
            entry[1], maneuver=scale_to_robot(source, robot)
        )  # as validate_maneuver does
    result = validate_maneuver(source, robot, dry_solve=True)
    with _CHECKED_LOCK:
        _CHECKED[key] = (robot, result)
        while len(_CHECKED) > _CHECKED_MAX:
            _CHECKED.popitem(last=False)
    return result
