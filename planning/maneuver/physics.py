"""The physics check of validation: the whole maneuver run closed-loop in MuJoCo, measured against its events.

`run_physics` is the headless run of `footfall run` and `POST /simulations` (planning.sim.run.ManeuverSession) with
a monitor that measures, per event, the phase the event starts (from its time to the next event of any leg): the
peak joint torque against the joint's limit, the peak friction use of the feet in contact (tangential over normal
force, against the maneuver's friction coefficient), the smallest stability margin (the capture point's signed
distance to the support polygon, m; negative outside) and the backup controller's ticks. The run stops early once
its failure is certain (a fall, or more backup ticks than a successful run may have), so a broken maneuver costs
less than a whole run.

`judge_physics` turns the run report into validation problems: a fall, a missed touchdown window, a run the backup
controller carried or a final pose off its keyframe is a failure naming the event most responsible; the per-event
margins are returned as the `physics` section of the validation answer (the studio draws them on its timeline).
"""

from __future__ import annotations

import dataclasses
import math
import time
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import mujoco
import numpy as np

from planning.maneuver.problems import Problem, with_lines

if TYPE_CHECKING:
    from planning.maneuver.spec import Maneuver
    from planning.maneuver.validate import ValidationResult
    from planning.robot import RobotModel
    from planning.sim.run import RunOptions

GRAVITY_MPS2 = 9.81
TIMING_SLACK_S = (
    0.1  # the run report's tolerance beyond an adjust window (planning.sim.metrics.match_touchdowns)
)
PLACE_SLACK_M = 0.08


@dataclass(frozen=True)
class PhysicsParams:
    """What the margins are measured against and when a mark is drawn as a warning."""

    stability_sample_s: float = 0.02  # the capture point is checked this often, s
    min_normal_share: float = 0.1  # a foot pressing less than this share of a quarter of the weight is not
    # counted for friction use (a foot just touching or leaving the ground slides for a tick or two)
    warn_use: float = 0.9  # torque or friction use above this share of its limit is a warning mark
    warn_margin: float = (
        0.25  # a normalized margin (1 = unused, 0 = at the limit) below this is a warning mark
    )


@dataclass
class _Phase:
    t: float
    torque_use: float = 0.0
    torque_nm: float = 0.0
    torque_joint: str = ""
    friction_use: float = 0.0
    stability_m: float = math.inf
    backup_ticks: int = 0


class MarginMonitor:
    """Watches every physics tick of a ManeuverSession and keeps the peaks of the phase each event starts."""

    def __init__(self, session: Any, params: PhysicsParams) -> None:
        self.session = session
        self.params = params
        robot: RobotModel = session.robot
        self.tau_max = np.where(robot.tau_max > 0, robot.tau_max, np.inf)
        self.joint_names = ("abduction", "hip", "knee")
        self.mu = float(session.maneuver.friction)
        self.min_fn = params.min_normal_share * robot.mass_kg * GRAVITY_MPS2 / 4.0
        self.world = session.world
        self.foot_of = {int(g): leg for leg, g in enumerate(self.world.foot_geom)}
        self.events = session.schedule.events()
        # events at the same time (a jump's four touchdowns) start one phase together
        self.starts = np.unique(np.round([e.t for e in self.events], 6)) if self.events else np.zeros(0)
        self.phases = [_Phase(float(t)) for t in self.starts]
        self.phase_of = [int(np.searchsorted(self.starts, round(e.t, 6))) for e in self.events]
        self.before = _Phase(0.0)  # the time before the first event
        self._next_stab = 0.0
        self._force = np.zeros(6)
        self._fallbacks = 0
        self.tau = np.zeros((4, 3))
        driver = getattr(session.controller, "driver", None)
        self.driver = driver
        actuate = session.loop.actuate

        def recording_actuate(s: Any) -> np.ndarray:
            tau = actuate(s)
            self.tau = tau
            return tau  # type: ignore[no-any-return]

        session.loop.actuate = recording_actuate

    def phase(self, t: float) -> _Phase:
        k = int(np.searchsorted(self.starts, t + 1e-9, side="right")) - 1
        return self.before if k < 0 else self.phases[k]

    def __call__(self, s: Any) -> None:
        ph = self.phase(s.t)
        use = np.abs(self.tau) / self.tau_max
        k = int(np.argmax(use))
        if use.flat[k] > ph.torque_use:
            ph.torque_use = float(use.flat[k])
            ph.torque_nm = float(abs(self.tau.flat[k]))
            ph.torque_joint = f"{('FL', 'FR', 'RL', 'RR')[k // 3]} {self.joint_names[k % 3]}"
        if self.driver is not None:
            n = int(self.driver.fallback_ticks)
            if n > self._fallbacks:
                ph.backup_ticks += n - self._fallbacks
                self._fallbacks = n
        m, d = self.world.model, self.world.data
        for i in range(d.ncon):
            c = d.contact[i]
            if int(c.geom1) not in self.foot_of and int(c.geom2) not in self.foot_of:
                continue
            mujoco.mj_contactForce(m, d, i, self._force)
            fn = self._force[0]
            if fn >= self.min_fn:
                u = float(math.hypot(self._force[1], self._force[2]) / (self.mu * fn))
                if u > ph.friction_use:
                    ph.friction_use = u
        if s.t + 1e-9 >= self._next_stab:
            self._next_stab = s.t + self.params.stability_sample_s
            margin = self._capture_margin(s)
            if margin is not None and margin < ph.stability_m:
                ph.stability_m = margin

    def _capture_margin(self, s: Any) -> float | None:
        feet = s.p_world_foot[s.contact, :2]
        if len(feet) == 0:
            return None
        h = max(float(s.p_world_com[2] - np.mean(s.p_world_foot[s.contact, 2])), 0.05)
        cp = s.p_world_com[:2] + s.v_world_com[:2] * math.sqrt(h / GRAVITY_MPS2)
        return signed_distance_to_hull(cp, feet)

    def rows(self, report: dict[str, Any], explicit_paths: frozenset[str]) -> list[dict[str, Any]]:
        """Returns one row per event: what was measured in its phase and, for touchdowns, the run's errors."""
        tds = {(r["leg"], round(float(r["planned_t"]), 3)): r for r in report.get("touchdowns", [])}
        swings = {(sw.leg, round(sw.t_touchdown, 3)): sw for sw in self.session.schedule.all_swings()}
        t_end = float(report.get("duration_s") or 0.0)
        out = []
        for ev, k in zip(self.events, self.phase_of, strict=True):
            ph = self.phases[k]
            row: dict[str, Any] = {
                "t": round(ev.t, 4),
                "leg": ("FL", "FR", "RL", "RR")[ev.leg],
                "type": ev.type,
                "path": ev.path,
                "phase": k,
                "explicit": ev.path in explicit_paths,
                "reached": ev.t <= t_end + 1e-9,
                "peak_torque_use": round(ph.torque_use, 3),
                "peak_torque_nm": round(ph.torque_nm, 1),
                "peak_torque_joint": ph.torque_joint,
                "friction_use": round(ph.friction_use, 3),
                "stability_margin_m": None if math.isinf(ph.stability_m) else round(ph.stability_m, 3),
                "backup_ticks": ph.backup_ticks,
            }
            if ev.type == "touchdown":
                td = tds.get((row["leg"], round(ev.t, 3)))
                sw = swings.get((ev.leg, round(ev.t, 3)))
                row["time_window_s"] = round(float(sw.adjust.time_s), 3) if sw is not None else 0.0
                row["place_window_m"] = round(float(sw.adjust.radius_m or 0.0), 3) if sw is not None else 0.0
                if td is not None and td.get("actual_t") is not None:
                    row["timing_error_s"] = round(float(td["actual_t"]) - ev.t, 4)
                    row["place_error_m"] = td["error_m"]
                    row["within_window"] = bool(td["within_window"])
                elif td is not None:
                    row["timing_error_s"] = row["place_error_m"] = None
                    row["within_window"] = False
            out.append(row)
        return out


def signed_distance_to_hull(p: np.ndarray, pts: np.ndarray) -> float:
    """Returns the signed distance (m) of point p to the convex hull of 2-D points: positive inside, negative
    outside; a hull of one or two points (a foot, a diagonal pair) has no inside, so the answer is ≤ 0."""
    pts = np.asarray(pts, dtype=float)
    if len(pts) == 1:
        return -float(np.linalg.norm(p - pts[0]))
    hull = _convex_hull(pts)
    if len(hull) < 3:
        a, b = hull[0], hull[-1]
        return -_segment_distance(p, a, b)
    inside = True
    best = math.inf
    n = len(hull)
    for i in range(n):
        a, b = hull[i], hull[(i + 1) % n]
        e = b - a
        cross = e[0] * (p[1] - a[1]) - e[1] * (p[0] - a[0])  # > 0: p left of a→b (inside for a CCW hull)
        if cross < 0:
            inside = False
        best = min(best, _segment_distance(p, a, b))
    return best if inside else -best


def _segment_distance(p: np.ndarray, a: np.ndarray, b: np.ndarray) -> float:
    e = b - a
    L2 = float(e @ e)
    u = 0.0 if L2 <= 1e-12 else min(1.0, max(0.0, float((p - a) @ e) / L2))
    return float(np.linalg.norm(p - (a + u * e)))


def _convex_hull(pts: np.ndarray) -> np.ndarray:
    """Returns the counter-clockwise convex hull of 2-D points (monotone chain)."""
    P = sorted({(float(x), float(y)) for x, y in pts})
    if len(P) <= 2:
        return np.array(P)

    def cross(o: tuple[float, float], a: tuple[float, float], b: tuple[float, float]) -> float:
        return (a[0] - o[0]) * (b[1] - o[1]) - (a[1] - o[1]) * (b[0] - o[0])

    lower: list[tuple[float, float]] = []
    for q in P:
        while len(lower) >= 2 and cross(lower[-2], lower[-1], q) <= 0:
            lower.pop()
        lower.append(q)
    upper: list[tuple[float, float]] = []
    for q in reversed(P):
        while len(upper) >= 2 and cross(upper[-2], upper[-1], q) <= 0:
            upper.pop()
        upper.append(q)
    return np.array(lower[:-1] + upper[:-1])


class PhysicsRun:
    """One physics check: the ManeuverSession of `footfall run` with a MarginMonitor on its loop. `.session` stays
    available after `.run()` (tests look at what the robot did)."""

    def __init__(
        self,
        maneuver: Maneuver,
        options: RunOptions | None = None,
        params: PhysicsParams | None = None,
        robot_model: RobotModel | None = None,
    ) -> None:
        from planning.sim.run import ManeuverSession, RunOptions

        self.options = opts = options or RunOptions()
        self.session = ManeuverSession(maneuver, opts, robot_model)
        self.monitor = MarginMonitor(self.session, params or PhysicsParams())
        self.session.loop.monitors.append(self.monitor)

    def run(self, progress: Any = None) -> dict[str, Any]:
        """Runs to the end, a fall, or a certain failure; returns the run report with its "events" margins."""
        from planning.sim.run import MAX_BACKUP_SHARE

        session, monitor = self.session, self.monitor
        duration = (
            self.options.duration_s if self.options.duration_s is not None else session.maneuver.duration
        )
        balance_hz = next((st.rate_hz for st in session.controller.stages if st.name == "balance"), 0.0)
        allowed_backup = MAX_BACKUP_SHARE * balance_hz * float(duration)

        def certain_failure() -> bool:
            # more backup ticks than a whole successful run may have: the verdict is in, the rest is not needed
            return monitor.driver is not None and monitor.driver.fallback_ticks > allowed_backup

        t0 = time.perf_counter()
        session.loop.run(float(duration), progress=progress, should_stop=certain_failure)
        report = session.report(time.perf_counter() - t0)
        report["stopped_early"] = bool(session.world.t < float(duration) - 1e-6 and not report["fell"])
        explicit = frozenset(f"events[{i}]" for i in range(len(session.maneuver.events)))
        report["events"] = monitor.rows(report, explicit)
        return report


def run_physics(
    maneuver: Maneuver,
    options: RunOptions | None = None,
    progress: Any = None,
    params: PhysicsParams | None = None,
    robot_model: RobotModel | None = None,
) -> dict[str, Any]:
    """Runs the maneuver headless (the code of `footfall run`) and returns its run report with an "events" list:
    per event, the margins measured in the phase it starts. Stops early once the run has certainly failed."""
    return PhysicsRun(maneuver, options, params, robot_model).run(progress)


def judge_physics(
    report: dict[str, Any], params: PhysicsParams | None = None
) -> tuple[list[Problem], list[Problem], dict[str, Any]]:
    """Returns (failures, warnings, physics section) of a physics-check run report.

    A failed run gives one failure, on the event most responsible: for a fall, the last event at or before it
    (among events at the same time, the one with the smallest margin); for a missed window, that touchdown; for a
    run the backup controller carried, the event whose phase had the most backup ticks; for a final pose off its
    keyframe, the whole body track."""
    pr = params or PhysicsParams()
    events = [dict(e) for e in report.get("events") or []]
    for e in events:
        e["margin"] = round(_margin(e), 3)
        e["status"] = "ok" if e["margin"] >= pr.warn_margin else "warning"
        if not e.get("reached", True):
            e["status"] = "not reached"
    failures: list[Problem] = []
    responsible: dict[str, Any] | None = None
    success = bool(report.get("success", False))
    reason = str(report.get("failure_reason") or "the run did not succeed")
    if not success:
        reached = [e for e in events if e.get("reached", True)]
        if report.get("fell"):
            t_fall = float(report.get("fall_time_s") or report.get("duration_s") or 0.0)
            before = [e for e in reached if e["t"] <= t_fall + 1e-9]
            if before:
                t_last = max(e["t"] for e in before)
                responsible = min(
                    (e for e in before if abs(e["t"] - t_last) < 1e-6), key=lambda e: e["margin"]
                )
        else:
            missed = [e for e in reached if e["type"] == "touchdown" and e.get("within_window") is False]
            if missed:
                responsible = missed[0]
            elif "backup controller" in reason and reached:
                busiest = max(reached, key=lambda e: e.get("backup_ticks", 0))
                if busiest.get("backup_ticks", 0) > 0:
                    responsible = busiest
        if responsible is not None:
            responsible["status"] = "failure"
            what = f"the {responsible['type']} of {responsible['leg']} at {responsible['t']:g} s"
            failures.append(
                Problem(
                    responsible["path"],
                    f"the physics check fails after {what}: {reason}{_numbers(responsible)}",
                )
            )
        elif "final pose" in reason:
            failures.append(Problem("body", f"the physics check fails: {reason}"))
        else:
            failures.append(Problem("", f"the physics check fails: {reason}"))
    warnings = []
    warned: set[Any] = set()
    for e in sorted(events, key=lambda e: e["margin"]):
        if e["status"] != "warning" or not e.get("explicit") or e.get("phase") in warned:
            continue
        warned.add(e.get("phase"))  # one warning per phase (a jump's four touchdowns share theirs)
        warnings.append(Problem(e["path"], f"in the physics check, the {e['type']} of {e['leg']} at {e['t']:g} s "
                                           f"comes close to a limit{_numbers(e)}", "warning"))  # fmt: skip
    timing = report.get("timing") or {}
    section = {
        "ran": True,
        "success": success,
        "fell": bool(report.get("fell", False)),
        "fall_time_s": report.get("fall_time_s"),
        "failure_reason": None if success else reason,
        "stopped_early": bool(report.get("stopped_early", False)),
        "simulated_s": report.get("duration_s"),
        "wall_s": timing.get("wall_s"),
        "rtf": timing.get("rtf"),
        "responsible": None
        if responsible is None
        else {k: responsible[k] for k in ("t", "leg", "type", "path")},
        "events": events,
    }
    return failures, warnings, section


def _margin(e: dict[str, Any]) -> float:
    """Returns an event's smallest normalized margin: 1 = nothing used, 0 = at a limit, < 0 = past it."""
    m = min(1.0 - float(e.get("peak_torque_use", 0.0)), 1.0 - float(e.get("friction_use", 0.0)))
    if e.get("type") == "touchdown":
        if e.get("within_window") is False:
            m = min(m, -1.0)
        dt = e.get("timing_error_s")
        if dt is not None:
            m = min(m, 1.0 - abs(float(dt)) / (float(e.get("time_window_s", 0.0)) + TIMING_SLACK_S))
        dp = e.get("place_error_m")
        if dp is not None:
            m = min(m, 1.0 - float(dp) / (float(e.get("place_window_m", 0.0)) + PLACE_SLACK_M))
    if e.get("backup_ticks", 0) > 0:
        m = min(m, 0.0)
    return m


def _numbers(e: dict[str, Any]) -> str:
    parts = [f"peak torque {e.get('peak_torque_use', 0.0):.0%} of the limit ({e.get('peak_torque_joint', '')})",
             f"friction use {e.get('friction_use', 0.0):.0%}"]  # fmt: skip
    if e.get("stability_margin_m") is not None:
        parts.append(f"stability margin {e['stability_margin_m'] * 100:+.0f} cm")
    if e.get("timing_error_s") is not None:
        parts.append(f"touchdown {e['timing_error_s'] * 1e3:+.0f} ms, {e['place_error_m'] * 100:.1f} cm off")
    if e.get("backup_ticks"):
        parts.append(f"{e['backup_ticks']} backup ticks")
    return " (" + "; ".join(parts) + ")"


def with_physics(
    result: ValidationResult, report: dict[str, Any], lines: dict[str, int] | None = None
) -> ValidationResult:
    """Returns a validation result with the physics check's run report judged into it (failures, warnings and
    the `physics` section)."""
    failures, warnings, section = judge_physics(report)
    return dataclasses.replace(
        result,
        ok=result.ok and not failures,
        failures=[*result.failures, *with_lines(failures, lines)],
        warnings=[*result.warnings, *with_lines(warnings, lines)],
        physics=section,
    )


def skipped(result: ValidationResult, reason: str) -> ValidationResult:
    """Returns the result with a `physics` section saying the physics check did not run, and why."""
    return dataclasses.replace(result, physics={"ran": False, "reason": reason, "events": []})


def check_with_physics(
    maneuver: Maneuver,
    robot: RobotModel,
    options: RunOptions | None = None,
    lines: dict[str, int] | None = None,
) -> ValidationResult:
    """The whole validation in this process: shape, rules and dry solve (check_maneuver), then, when those pass,
    the physics check. `maneuver` as written (the run scales it to the robot, as `footfall run` does)."""
    from planning.maneuver.validate import check_maneuver
    from planning.sim.run import RunOptions

    result = check_maneuver(maneuver, robot)
    if lines:
        result = dataclasses.replace(
            result, warnings=with_lines(result.warnings, lines), failures=with_lines(result.failures, lines)
        )
    if not result.ok:
        return skipped(result, "the maneuver has failures without simulating it")
    opts = options or RunOptions(robot=robot.name)
    return with_physics(result, run_physics(maneuver, opts, robot_model=robot), lines)
