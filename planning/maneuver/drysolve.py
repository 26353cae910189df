"""The dry solve of `footfall validate`: run the centroidal solver along the maneuver on its own predictions.

Starting from the nominal stand, each step solves the problem of the moment and advances to the solution's own
state a little later (no simulator), as the real loop would if the robot did exactly what was planned. It reports
warnings where the solver had to move a touchdown (in time or place) and failures where even every adjustment
leaves the problem infeasible, naming the event and the constraint.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from planning.centroidal.problem import BodyState
from planning.centroidal.solver import CentroidalParams, CentroidalSolver
from planning.geometry import rpy_to_R
from planning.maneuver.body import BodyReference
from planning.maneuver.expand import Schedule
from planning.maneuver.generator import ProblemGenerator
from planning.maneuver.problems import Problem
from planning.maneuver.spec import Maneuver
from planning.robot import LEGS, RobotModel


@dataclass(frozen=True)
class DrySolveParams:
    step_s: float = 0.2  # s between dry ticks
    moved_time_s: float = 0.01  # a touchdown moved by more than this in time is reported
    moved_place_m: float = 0.01  # ... or by more than this in place
    max_failures: int = 5


def dry_solve(
    maneuver: Maneuver,
    schedule: Schedule,
    body: BodyReference,
    robot: RobotModel,
    params: DrySolveParams | None = None,
) -> list[Problem]:
    """Returns warnings (touchdowns the solver moved) and failures (infeasible even with every adjustment)."""
    pr = params or DrySolveParams()
    gen = ProblemGenerator(maneuver, schedule, body, robot)
    solver = CentroidalSolver(CentroidalParams(time_budget_ms=math.inf), robot=robot)  # deterministic
    paths = {}
    for sw in schedule.all_swings():
        paths[(sw.leg, round(sw.t_touchdown, 4))] = sw.touchdown_path
    p0, v0, rpy0, w0 = body.sample(0.0)
    R0 = rpy_to_R(rpy0)
    state = BodyState(0.0, p0 + R0 @ gen.model.p_body_com, v0, R0, w0)
    moved: dict[str, Problem] = {}
    failures: list[Problem] = []
    late_until = np.full(4, -np.inf)  # a touchdown the solver moved later keeps its foot up until then
    t = 0.0
    while t < maneuver.duration - 1e-9 and len(failures) < pr.max_failures:
        # the robot does what was planned: the plan's contacts, with the solver's moved touchdowns, are "measured"
        contact = np.array([schedule.swing_at(leg, t) is None and t >= late_until[leg] for leg in range(4)])
        feet = np.array([schedule.foot_position(leg, t) for leg in range(4)])
        sol = solver.solve(gen.problem_at(state, contact, feet))
        if sol.status in ("infeasible", "invalid") or (not sol.ok and sol.p_world.shape[0] < 2):
            nxt = next((e for e in schedule.events() if e.t >= t - 1e-9), None)
            where = nxt.path if nxt is not None else ""
            what = (
                f"the {nxt.type} of {LEGS[nxt.leg]} at {nxt.t:g} s" if nxt is not None else "the final pose"
            )
            failures.append(
                Problem(where, f"the solver finds no feasible plan at {t:.2f} s before {what}: {sol.message}")
            )
            t += pr.step_s
            continue
        for td in sol.touchdowns:
            path = paths.get((td.leg, round(td.t_nominal, 4)))
            if path is None or td.planted:
                continue
            dt = td.t - td.t_nominal
            dp = float(np.linalg.norm(np.asarray(td.p_world)[:2] - np.asarray(td.p_world_nominal)[:2]))
            if dt > 0.0 and td.t_nominal <= t + pr.step_s + 1e-9:
                late_until[td.leg] = td.t
            if abs(dt) > pr.moved_time_s or dp > pr.moved_place_m:
                moved[path] = Problem(
                    path,
                    f"the solver moves the touchdown of {LEGS[td.leg]} by {dt * 1e3:+.0f} ms and {dp * 100:.1f} cm "
                    "(within its adjust window) to make the plan work",
                    "warning",
                )
        # advance on the solution's own prediction to the knot nearest to t + step
        k = int(np.argmin(np.abs(sol.t_knots - (t + pr.step_s))))
        k = max(k, 1)
        t = float(sol.t_knots[k])
        state = BodyState(t, sol.p_world[k], sol.v_world[k], sol.R_world_body[k], sol.omega_world[k])
    return [*failures, *moved.values()]
