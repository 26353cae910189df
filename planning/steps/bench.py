"""Timing of step-path selection (Eq. 1 scoring of N candidates) and of a whole replan."""

from __future__ import annotations

import time

import numpy as np

from planning.steps.gait import GAITS, GaitClock
from planning.steps.lip import state_omega
from planning.steps.potential import (
    Constraints,
    Octagon,
    PotentialParams,
    _generate,
    build_batch,
    potential_step_paths,
)
from planning.steps.reference import reference_step_path
from planning.steps.select import WeightPresets, select_step_path
from planning.steps.state import SteeringCommand, StepPath, WalkState, standing_state


def _scenario(robot: object, i: int) -> tuple[WalkState, SteeringCommand, GaitClock]:
    """A trotting robot at 0.8 m/s with a varying velocity error (as after pushes)."""
    rng = np.random.default_rng(i)
    t = 0.37 + 0.013 * i
    state = standing_state(robot, t=t, xy=(0.8 * t, 0.0), v_xy=(0.8 + rng.normal(0, 0.1), rng.normal(0, 0.2)))  # type: ignore[arg-type]
    return state, SteeringCommand(0.8, 0.0, 0.1), GaitClock("trot", t0=0.0)


def _exact_candidates(ref: StepPath, state: WalkState, robot: object, n: int) -> list[StepPath]:
    """Returns exactly n generated candidates (unscreened, so the count does not depend on the scenario)."""
    p = PotentialParams()
    fam = _generate(ref, state, Octagon.of(robot, Constraints()), n, p, state_omega(state, 0.52), None)  # type: ignore[arg-type]
    while len(fam.kind) < n:  # tiny n: repeat the reference
        fam.add(ref.p_world_touchdown[:, :2], "reference")
    b = build_batch(ref, fam, None)
    return [
        StepPath(ref.leg, b.t_td[i], b.t_lo[i], b.p_td[i], b.t_lo_now[i], ref.body, fam.kind[i], ref.gait)
        for i in range(n)
    ]


def bench_step_selection(
    n_candidates: int = 25, n_calls: int = 300, robot_name: str = "spot"
) -> dict[str, float]:
    """Returns selection time per replan with n_candidates (p50_ms, p99_ms), and the whole replan's (reference +
    potential paths + screening + selection: replan_p50_ms, replan_p99_ms), over n_calls calls."""
    from planning.robot import load_robot

    robot = load_robot(robot_name)
    sel_ms: list[float] = []
    replan_ms: list[float] = []
    weights = WeightPresets.DEFAULT
    for i in range(n_calls):
        state, cmd, clock = _scenario(robot, i)
        ref = reference_step_path(cmd, state, robot, GAITS["trot"], clock, state.t)
        cands = _exact_candidates(ref, state, robot, n_candidates)
        t0 = time.perf_counter()
        select_step_path(ref, cands, state, weights)
        sel_ms.append((time.perf_counter() - t0) * 1e3)
        t0 = time.perf_counter()
        ref = reference_step_path(cmd, state, robot, GAITS["trot"], clock, state.t)
        paths = potential_step_paths(ref, state, robot, n=n_candidates)
        select_step_path(ref, paths, state, weights)
        replan_ms.append((time.perf_counter() - t0) * 1e3)
    return {
        "n_candidates": float(n_candidates),
        "p50_ms": float(np.percentile(sel_ms, 50)),
        "p99_ms": float(np.percentile(sel_ms, 99)),
        "replan_p50_ms": float(np.percentile(replan_ms, 50)),
        "replan_p99_ms": float(np.percentile(replan_ms, 99)),
    }


def bench_steps() -> dict[str, float]:
    """Returns the selection and replan timings for 25 and 100 candidates (keys suffixed _25 and _100)."""
    out: dict[str, float] = {}
    for n in (25, 100):
        r = bench_step_selection(n)
        out.update({f"{k}_{n}": v for k, v in r.items() if k != "n_candidates"})
    out["p50_ms"] = out["p50_ms_25"]
    out["p99_ms"] = out["p99_ms_25"]
    return out


if __name__ == "__main__":
    for n in (25, 100):
        print(n, {k: round(v, 3) for k, v in bench_step_selection(n).items()})
