"""Recorded swing-planner inputs (closed-loop trots on flat ground, and the bench cases) replayed through a planner.

tests/swing/data/recorded_trot_inputs.json.gz holds two windows of consecutive plan() calls recorded in MuJoCo
(a 0.8 m/s trot; a 0.3 m/s forward, 0.2 m/s sideways, 0.8 rad/s turning trot) and the selections the planner
made on them before its set-up and selections were vectorized (``expected``).
"""

from __future__ import annotations

import gzip
import json
from pathlib import Path
from typing import Any

import numpy as np

from planning.swing import BodyMotion, SwingPlanner, SwingRequest
from planning.swing.bench import _case

DATA = Path(__file__).parent / "data" / "recorded_trot_inputs.json.gz"
BENCH_CASES = ("flat", "box", "crossing")


def load() -> dict[str, Any]:
    with gzip.open(DATA, "rt") as f:
        return json.load(f)  # type: ignore[no-any-return]


def replay_sequence(planner: SwingPlanner, seq: list[dict[str, Any]]) -> list[dict[str, list[Any]]]:
    """Plans every recorded call in order; returns per call {leg: [horizontal, vertical, tier, positions (5,3)]}."""
    out = []
    for c in seq:
        legs = [
            SwingRequest(leg, np.array(p), np.array(v), np.array(td), t_td)
            for leg, p, v, td, t_td in c["legs"]
        ]
        t0, p_b, R, v_b, wz = c["body"]
        body = BodyMotion(t0, np.array(p_b), np.array(R), np.array(v_b), wz)
        stance = {int(k): np.array(v) for k, v in c["stance"].items()}
        plans = planner.plan(c["t"], legs, stance_feet_world=stance, body=body)
        out.append(
            {
                str(k): [
                    p.horizontal_policy,
                    p.vertical_policy,
                    int(p.tier),
                    p.positions(np.linspace(c["t"], p.t_touchdown, 5)).tolist(),
                ]
                for k, p in plans.items()
            }
        )
    return out


def replay_bench_case(planner: SwingPlanner, name: str, calls: int = 60) -> list[dict[str, list[Any]]]:
    """Replans one leg from states along its own first plan, as the bench does (flat, box, crossing)."""
    req, ground, stance, body = _case(name)
    first = planner.plan(0.0, [req], ground, stance, body)[0]
    out = []
    horizon = req.t_touchdown - 0.03
    for k in range(calls):
        t = horizon * k / calls
        p, v, _ = first.sample(t)
        r = SwingRequest(0, p, v, req.p_touchdown, req.t_touchdown)
        plan = planner.plan(t, [r], ground, stance, BodyMotion(t, body.p_world_body, body.R_world_body))[0]
        out.append(
            {
                "0": [
                    plan.horizontal_policy,
                    plan.vertical_policy,
                    int(plan.tier),
                    plan.positions(np.linspace(t, plan.t_touchdown, 5)).tolist(),
                ]
            }
        )
    return out
