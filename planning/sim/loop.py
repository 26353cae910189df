"""The control loop: stages at their own rates in simulated time, fall detection, pacing and progress."""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

from planning.sim.world import RobotState, World


@dataclass
class Stage:
    """A named step of the controller that runs every 1/rate_hz seconds of simulated time.

    ``fn(state)`` reads the measured state; stages communicate through the controller that owns them. The loop
    records each call's wall time in ``times_ms`` for the report and the benchmark.
    """

    name: str
    rate_hz: float
    fn: Callable[[RobotState], None]
    times_ms: list[float] = field(default_factory=list)
    next_t: float = 0.0  # simulated time of its next run, s


@dataclass(frozen=True)
class FallCriteria:
    """When a run counts as a fall (CONTRACT.md): a non-foot contact, or the body below half its nominal height."""

    min_height_fraction: float = 0.5


@dataclass
class LoopResult:
    t_end: float
    wall_s: float
    fell: bool
    fall_time_s: float | None
    failure_reason: str | None

    @property
    def rtf(self) -> float:
        return self.t_end / self.wall_s if self.wall_s > 0 else float("inf")


ProgressFn = Callable[[float, float, float], None]  # (t_sim, duration, rtf)


class Loop:
    """Runs stages at their rates on a World; deterministic for the same inputs."""

    def __init__(
        self,
        world: World,
        stages: list[Stage],
        actuate: Callable[[RobotState], np.ndarray],
        fall: FallCriteria | None = None,
        monitors: list[Callable[[RobotState], None]] | None = None,
    ) -> None:
        self.world = world
        self.stages = stages
        self.actuate = actuate
        self.fall = fall or FallCriteria()
        self.monitors = monitors or []
        self.state = RobotState()
        for st in stages:
            st.next_t = world.t
        self.tick = 0
        self.fell = False
        self.fall_time: float | None = None
        self.failure_reason: str | None = None
        # a fall by touch: the robot's part (body name), what it is (World: trunk, upper or lower leg), the world geom
        # it touched and where (world, m)
        self.fall_contact: tuple[str, str | None, str | None, tuple[float, float, float]] | None = None
        self.min_height = self.fall.min_height_fraction * world.robot.standing_height_m
        world.read_state(self.state)

    def step(self) -> RobotState:
        """Runs one physics tick: read the state, run due stages, write torques, step physics."""
        s = self.world.read_state(self.state)
        eps = 1e-9
        for st in self.stages:
            # a stage runs at the first physics step at or after its time, so its average period is exactly its
            # declared one (a 3 ms stage on a 2 ms step runs after 2, 4, 2, 4 ... ms)
            if s.t + eps >= st.next_t:
                t0 = time.perf_counter()
                st.fn(s)
                st.times_ms.append((time.perf_counter() - t0) * 1e3)
                st.next_t = max(st.next_t + 1.0 / st.rate_hz, s.t + eps)
        tau = self.actuate(s)
        self.world.set_torques(tau)
        for mon in self.monitors:
            mon(s)
        if not self.fell:
            self._check_fall(s)
        self.world.step()
        self.tick += 1
        return s

    def _check_fall(self, s: RobotState) -> None:
        ground = self.world.scene.ground_height(float(s.p_world_body[0]), float(s.p_world_body[1]))
        reason = None
        if s.bad_contact is not None:
            reason = f"{s.bad_contact} touched the world at t={s.t:.2f} s"
            x, y, z = s.bad_contact_at.tolist()
            self.fall_contact = (s.bad_contact, s.bad_contact_kind, s.bad_contact_with, (x, y, z))
        elif s.p_world_body[2] - ground < self.min_height:
            reason = f"body dropped to {s.p_world_body[2] - ground:.2f} m at t={s.t:.2f} s"
        if reason is not None:
            self.fell = True
            self.fall_time = s.t
            self.failure_reason = f"fell: {reason}"

    def run(
        self,
        duration_s: float,
        realtime: bool = False,
        progress: ProgressFn | None = None,
        stop_on_fall: bool = True,
        should_stop: Callable[[], bool] | None = None,
    ) -> LoopResult:
        """Runs until duration_s of simulated time (or a fall); paces to the wall clock when realtime."""
        dt = self.world.dt
        n = int(round(duration_s / dt))
        t_wall0 = time.perf_counter()
        t_sim0 = self.world.t
        next_progress = 0.5
        for _ in range(n):
            self.step()
            if self.fell and stop_on_fall:
                # keep simulating a little so the fall is visible, but the verdict is in
                break
            elapsed = time.perf_counter() - t_wall0
            sim_elapsed = self.world.t - t_sim0
            if realtime and sim_elapsed > elapsed:
                time.sleep(sim_elapsed - elapsed)
            if progress is not None and elapsed >= next_progress:
                progress(self.world.t, duration_s, sim_elapsed / max(elapsed, 1e-9))
                next_progress = elapsed + 0.25
            if should_stop is not None and self.tick % 50 == 0 and should_stop():
                break
        wall = time.perf_counter() - t_wall0
        return LoopResult(self.world.t - t_sim0, wall, self.fell, self.fall_time, self.failure_reason)
