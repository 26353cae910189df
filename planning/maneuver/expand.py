"""Gait segments and sparse events → a canonical contact `Schedule`: per leg, its swings in time order.

A swing is the time a foot spends in the air: [t_liftoff, t_touchdown). At t_liftoff the foot is in the air, at
t_touchdown it is on the ground again. Positions are contact points in the maneuver frame (m); times in seconds.
"""

from __future__ import annotations

import heapq
import math
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import numpy as np

from planning.maneuver.problems import ManeuverError, Problem
from planning.maneuver.spec import Adjust, Gait, Liftoff, Maneuver, Touchdown

if TYPE_CHECKING:
    from planning.robot import RobotModel

LEGS: tuple[str, str, str, str] = ("FL", "FR", "RL", "RR")
LEG_INDEX: dict[str, int] = {name: i for i, name in enumerate(LEGS)}
MAX_EVENTS = 2000  # liftoffs + touchdowns after gait expansion
FRONT, REAR = (0, 1), (2, 3)

# When each leg lifts off within a gait cycle, as a fraction of the cycle (touchdown follows (1 - duty) later).
GAIT_PHASES: dict[str, tuple[float, float, float, float]] = {
    #          FL     FR     RL     RR
    "trot":  (0.00,  0.50,  0.50,  0.00),   # diagonal pairs FL+RR / FR+RL
    "pace":  (0.00,  0.50,  0.00,  0.50),   # lateral pairs FL+RL / FR+RR
    "bound": (0.00,  0.00,  0.50,  0.50),   # front pair / rear pair
    "walk":  (0.25,  0.75,  0.00,  0.50),   # crawl, four beats: RL, FL, RR, FR
    "pronk": (0.00,  0.00,  0.00,  0.00),   # all four together
}  # fmt: skip


def leg_index(leg: int | str) -> int:
    """Returns the index 0..3 of a leg given as index or name (FL, FR, RL, RR)."""
    if isinstance(leg, str):
        return LEG_INDEX[leg]
    if not 0 <= int(leg) < 4:
        raise IndexError(f"leg index {leg} is not in 0..3")
    return int(leg)


@dataclass(frozen=True, eq=False)
class AdjustWindow:
    """How far the planner may move a touchdown: ± time_s in time, within radius_m or inside region_xy (K,2)."""

    time_s: float = 0.0
    radius_m: float | None = None
    region_xy: np.ndarray | None = None  # (K,2) polygon, maneuver frame, m

    @staticmethod
    def of(adjust: Adjust | None) -> AdjustWindow:
        if adjust is None:
            return AdjustWindow()
        region = None if adjust.region is None else np.array(adjust.region, dtype=float).reshape(-1, 2)
        return AdjustWindow(adjust.time, adjust.radius, region)


@dataclass(frozen=True, eq=False)
class Swing:
    """One foot's flight: lifts off at p_liftoff, lands at p_touchdown (contact points, maneuver frame, m)."""

    leg: int
    t_liftoff: float
    t_touchdown: float
    p_liftoff: np.ndarray  # (3,)
    p_touchdown: np.ndarray  # (3,)
    normal: np.ndarray  # (3,) unit contact normal at the touchdown
    adjust: AdjustWindow  # the touchdown's window
    liftoff_adjust_s: float  # ± s the liftoff may move
    height_m: float | None  # swing apex height; None: the swing planner's default
    liftoff_path: str  # where it came from in the file: "events[2]" or "gaits[0]"
    touchdown_path: str
    waypoints: np.ndarray | None = None  # (K,4) [t, x, y, z]: points the foot passes through, maneuver frame

    @property
    def duration_s(self) -> float:
        return self.t_touchdown - self.t_liftoff


@dataclass(frozen=True)
class ScheduledEvent:
    """A liftoff or touchdown of the expanded schedule, with the file path it came from."""

    t: float
    leg: int
    type: str  # "liftoff" | "touchdown"
    path: str


@dataclass(frozen=True, eq=False)
class Schedule:
    """Per leg (FL, FR, RL, RR) the swings in time order; everything else is stance."""

    duration_s: float
    p_start_foot: np.ndarray  # (4,3) contact points at t = 0, maneuver frame, m
    swings: tuple[tuple[Swing, ...], tuple[Swing, ...], tuple[Swing, ...], tuple[Swing, ...]]
    _t_lo: tuple[np.ndarray, ...] = field(init=False, repr=False)
    _t_td: tuple[np.ndarray, ...] = field(init=False, repr=False)

    def __post_init__(self) -> None:
        object.__setattr__(self, "_t_lo", tuple(np.array([s.t_liftoff for s in sw]) for sw in self.swings))
        object.__setattr__(self, "_t_td", tuple(np.array([s.t_touchdown for s in sw]) for sw in self.swings))

    def swing_at(self, leg: int | str, t: float) -> Swing | None:
        """Returns the swing of `leg` in progress at time t (s), or None when the foot is on the ground."""
        i = leg_index(leg)
        k = int(np.searchsorted(self._t_lo[i], t, side="right")) - 1
        if k >= 0 and t < self._t_td[i][k]:
            return self.swings[i][k]
        return None

    def in_stance(self, leg: int | str, t: float) -> bool:
        """Returns whether the foot of `leg` is on the ground at time t (s)."""
        return self.swing_at(leg, t) is None

    def stance_mask(self, t: float) -> np.ndarray:
        """Returns (4,) bool: which feet are on the ground at time t (s)."""
        return np.array([self.swing_at(i, t) is None for i in range(4)])

    def next_touchdown(self, leg: int | str, t: float) -> Swing | None:
        """Returns the first swing of `leg` that lands strictly after time t (s), or None."""
        i = leg_index(leg)
        k = int(np.searchsorted(self._t_td[i], t, side="right"))
        return self.swings[i][k] if k < len(self.swings[i]) else None

    def foot_position(self, leg: int | str, t: float) -> np.ndarray:
        """Returns (3,) the foot's contact point at t: where it stands, or where it lifted off while swinging."""
        i = leg_index(leg)
        k = int(np.searchsorted(self._t_lo[i], t, side="right")) - 1
        if k < 0:
            return self.p_start_foot[i].copy()
        s = self.swings[i][k]
        return (s.p_liftoff if t < s.t_touchdown else s.p_touchdown).copy()

    def foot_target(self, leg: int | str, t: float) -> np.ndarray:
        """Returns (3,) where the foot is (stance) or is going to land (swing) at time t, maneuver frame, m."""
        i = leg_index(leg)
        k = int(np.searchsorted(self._t_lo[i], t, side="right")) - 1
        return (self.p_start_foot[i] if k < 0 else self.swings[i][k].p_touchdown).copy()

    def foot_normal(self, leg: int | str, t: float) -> np.ndarray:
        """Returns (3,) the unit contact normal of the foot's current (or, while swinging, last) contact."""
        i = leg_index(leg)
        k = int(np.searchsorted(self._t_td[i], t, side="right")) - 1
        return np.array([0.0, 0.0, 1.0]) if k < 0 else self.swings[i][k].normal.copy()

    def feet_at(self, t: float) -> np.ndarray:
        """Returns (4,3) the contact points at time t (liftoff points for swinging feet)."""
        return np.array([self.foot_position(i, t) for i in range(4)])

    def events(self) -> list[ScheduledEvent]:
        """Returns every liftoff and touchdown, sorted by time then leg."""
        out = []
        for sw in self.swings:
            for s in sw:
                out.append(ScheduledEvent(s.t_liftoff, s.leg, "liftoff", s.liftoff_path))
                out.append(ScheduledEvent(s.t_touchdown, s.leg, "touchdown", s.touchdown_path))
        out.sort(key=lambda e: (e.t, e.leg, e.type == "liftoff"))
        return out

    @property
    def n_events(self) -> int:
        return 2 * sum(len(sw) for sw in self.swings)

    def all_swings(self) -> list[Swing]:
        """Returns every swing of every leg sorted by liftoff time."""
        return sorted((s for sw in self.swings for s in sw), key=lambda s: (s.t_liftoff, s.leg))


# ---- gaits -----------------------------------------------------------------------------------------------------
def _rot2(yaw: float) -> np.ndarray:
    c, s = math.cos(yaw), math.sin(yaw)
    return np.array([[c, -s], [s, c]])


def support_frame(p_foot: np.ndarray, nominal_xy: np.ndarray) -> tuple[float, float, float]:
    """Returns (x, y, yaw) of the body over feet p_foot (4,3), so that nominal_xy (4,2) around it fits them best.

    Yaw is the heading of rear-to-front midpoints relative to the nominal's; for the nominal stance it is (0, 0, 0).
    """
    d = p_foot[FRONT, :2].mean(axis=0) - p_foot[REAR, :2].mean(axis=0)
    d0 = nominal_xy[FRONT, :].mean(axis=0) - nominal_xy[REAR, :].mean(axis=0)
    yaw = math.atan2(d[1], d[0]) - math.atan2(d0[1], d0[0])
    c = p_foot[:, :2].mean(axis=0) - _rot2(yaw) @ nominal_xy.mean(axis=0)
    return float(c[0]), float(c[1]), yaw


@dataclass(frozen=True, eq=False)
class GaitPlan:
    """A gait segment expanded: swings (leg, t_liftoff, t_touchdown, p_touchdown_xy (2,)) and the cycle poses."""

    swings: list[tuple[int, float, float, np.ndarray]]
    t_cycle: np.ndarray  # (n+1,) cycle boundaries, s
    pose_cycle: np.ndarray  # (n+1,3) body [x, y, yaw] at each boundary, maneuver frame (m, rad)


def gait_cycles(gait: Gait) -> int:
    """Returns the number of whole cycles of a gait segment."""
    span = gait.to - gait.from_
    return max(0, int(math.floor(span / gait.cycle + 1e-9))) if span > 0 else 0


def gait_event_count(gait: Gait) -> int:
    """Returns how many liftoff + touchdown events a gait segment expands into (without building them)."""
    n = gait_cycles(gait)
    if n == 0:
        return 0
    swing = (1.0 - gait.duty) * gait.cycle
    last = gait.from_ + (n - 1) * gait.cycle
    dropped = sum(1 for ph in GAIT_PHASES[gait.gait] if last + ph * gait.cycle + swing > gait.to + 1e-9)
    return 2 * (4 * n - dropped)


def expand_gait(gait: Gait, p_foot: np.ndarray, nominal_xy: np.ndarray) -> GaitPlan:
    """Returns the swings of a gait segment starting with the feet at p_foot (4,3).

    The body advances by `step` (dx, dy in its own frame, dyaw) each cycle, starting from the support frame of
    p_foot; in cycle k every leg lands once, at its nominal place around the body pose that ends cycle k. Swings
    that would land after `to` are left out.
    """
    n = gait_cycles(gait)
    dx, dy, dyaw = gait.step[0], gait.step[1], math.radians(gait.step[2])
    poses = np.empty((n + 1, 3))
    poses[0] = support_frame(p_foot, nominal_xy)
    for k in range(n):
        x, y, yaw = poses[k]
        v = _rot2(yaw + 0.5 * dyaw) @ (dx, dy)  # heading at mid-cycle: a turning step follows the arc
        poses[k + 1] = (x + v[0], y + v[1], yaw + dyaw)
    swing_s = (1.0 - gait.duty) * gait.cycle
    phases = GAIT_PHASES[gait.gait]
    swings: list[tuple[int, float, float, np.ndarray]] = []
    for k in range(n):
        t0 = gait.from_ + k * gait.cycle
        p_xy = poses[k + 1, :2] + nominal_xy @ _rot2(poses[k + 1, 2]).T  # (4,2)
        for leg in range(4):
            t_lo = t0 + phases[leg] * gait.cycle
            t_td = t_lo + swing_s
            if t_td <= gait.to + 1e-9:
                swings.append((leg, t_lo, t_td, p_xy[leg]))
    t_cycle = gait.from_ + gait.cycle * np.arange(n + 1)
    return GaitPlan(swings, t_cycle, poses)


# ---- schedule --------------------------------------------------------------------------------------------------
def start_feet(robot: RobotModel) -> np.ndarray:
    """Returns the nominal stance contact points (4,3) in the maneuver frame (z = 0 on flat ground)."""
    p = np.array(robot.nominal_foot_body, dtype=float).reshape(4, 3).copy()
    p[:, 2] += float(robot.standing_height_m)
    return p


def count_events(maneuver: Maneuver) -> int:
    """Returns how many events the maneuver has after gait expansion (cheap: nothing is built)."""
    return len(maneuver.events) + sum(gait_event_count(g) for g in maneuver.gaits)


@dataclass
class _Open:
    """A swing in progress while the schedule is built."""

    t: float
    p: np.ndarray
    adjust_s: float
    path: str


@dataclass(frozen=True, eq=False)
class _Lift:
    leg: int
    path: str
    adjust_s: float = 0.0


@dataclass(frozen=True, eq=False)
class _Land:
    leg: int
    path: str
    adjust: AdjustWindow
    event: Touchdown | None = (
        None  # explicit: lands at `at`, at `offset` from the liftoff, or where it lifted off
    )
    p_xy: np.ndarray | None = None  # from a gait: lands here (z: that of its liftoff)
    height_m: float | None = None


def _target(land: _Land, p_liftoff: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Returns (touchdown point (3,), unit normal (3,)) of a landing that lifted off at p_liftoff."""
    ev = land.event
    if ev is None:
        assert land.p_xy is not None
        return np.array([land.p_xy[0], land.p_xy[1], p_liftoff[2]]), np.array([0.0, 0.0, 1.0])
    if ev.at is not None:
        p = np.array(ev.at, dtype=float)
    elif ev.offset is not None:
        p = p_liftoff + np.array(ev.offset, dtype=float)
    else:
        p = p_liftoff.copy()
    return p, _unit(ev.normal)


def _waypoints(land: _Land) -> np.ndarray | None:
    ev = land.event
    if ev is None or not ev.waypoints:
        return None
    return np.array(ev.waypoints, dtype=float).reshape(-1, 4)


def _unit(v: tuple[float, float, float]) -> np.ndarray:
    n = np.asarray(v, dtype=float)
    norm = float(np.linalg.norm(n))
    return n / norm if norm > 1e-12 and math.isfinite(norm) else np.array([0.0, 0.0, 1.0])


def build_schedule(maneuver: Maneuver, robot: RobotModel) -> Schedule:
    """Returns the contact schedule of a maneuver: explicit events and expanded gaits, paired per leg.

    Events are taken in time order (stable for equal times). Raises ManeuverError when a leg lifts off twice,
    lands without lifting off, never lands, or the expansion exceeds MAX_EVENTS; `validate_maneuver` reports the
    same conditions with more context.
    """
    n = count_events(maneuver)
    if n > MAX_EVENTS:
        raise ManeuverError([Problem("", f"expands into {n} events; at most {MAX_EVENTS} are allowed")])
    p_start = start_feet(robot)
    nominal_xy = p_start[:, :2].copy()
    p_foot = p_start.copy()
    open_: list[_Open | None] = [None] * 4
    swings: list[list[Swing]] = [[], [], [], []]
    problems: list[Problem] = []

    # heap items: (t, priority, seq, item); explicit events first at equal times, then gait starts, then the
    # events a gait generates (pushed when the gait starts, from the feet as they are then)
    heap: list[tuple[float, int, int, _Lift | _Land | tuple[str, Gait]]] = []
    for i, ev in enumerate(maneuver.events):
        path = f"events[{i}]"
        leg = LEG_INDEX[ev.leg]
        event: _Lift | _Land = (
            _Lift(leg, path, ev.adjust.time if ev.adjust else 0.0)
            if isinstance(ev, Liftoff)
            else _Land(leg, path, AdjustWindow.of(ev.adjust), event=ev)
        )
        heap.append((ev.t, 0, i, event))
    for j, g in enumerate(maneuver.gaits):
        heap.append((g.from_, 1, j, (f"gaits[{j}]", g)))
    heapq.heapify(heap)
    seq = len(heap)
    while heap:
        t, _, _, item = heapq.heappop(heap)
        if isinstance(item, tuple):
            path, g = item
            adj = AdjustWindow.of(g.adjust)
            for leg, t_lo, t_td, p_xy in expand_gait(g, p_foot, nominal_xy).swings:
                heapq.heappush(heap, (t_lo, 2, seq, _Lift(leg, path)))
                heapq.heappush(heap, (t_td, 2, seq + 1, _Land(leg, path, adj, p_xy=p_xy, height_m=g.height)))
                seq += 2
            continue
        leg, name = item.leg, LEGS[item.leg]
        o = open_[leg]
        if isinstance(item, _Lift):
            if o is not None:
                problems.append(
                    Problem(item.path, f"liftoff of {name} at {t:g} s while it is already in the air")
                )
            else:
                open_[leg] = _Open(t, p_foot[leg].copy(), item.adjust_s, item.path)
            continue
        if o is None:
            problems.append(Problem(item.path, f"touchdown of {name} at {t:g} s while it is on the ground"))
            continue
        p_td, normal = _target(item, o.p)
        swings[leg].append(
            Swing(
                leg,
                o.t,
                t,
                o.p,
                p_td,
                normal,
                item.adjust,
                o.adjust_s,
                item.height_m,
                o.path,
                item.path,
                _waypoints(item),
            )
        )
        p_foot[leg] = p_td
        open_[leg] = None
    for leg, o in enumerate(open_):
        if o is not None:
            problems.append(Problem(o.path, f"{LEGS[leg]} lifts off at {o.t:g} s and never touches down"))
    if problems:
        raise ManeuverError(problems)
    return Schedule(
        maneuver.duration,
        p_start,
        tuple(tuple(sorted(sw, key=lambda s: s.t_liftoff)) for sw in swings),  # type: ignore[arg-type]
    )
