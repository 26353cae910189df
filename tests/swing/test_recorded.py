"""The vectorized set-up and selections choose what the planner chose before, on recorded inputs.

Not bit for bit: a policy whose key ties another's to rounding may flip, so at least 98 % of the selections must
match, and where they match the trajectories must agree within a millimeter.
"""

from __future__ import annotations

import numpy as np
import pytest
from _swing_recorded import BENCH_CASES, load, replay_bench_case, replay_sequence

from planning.swing import SwingPlanner


def _compare(got: list[dict], want: list[dict]) -> tuple[int, int, float]:
    same = total = 0
    worst = 0.0
    assert len(got) == len(want)
    for g, w in zip(got, want, strict=True):
        assert set(g) == set(w)  # the same legs planned
        for leg, (h, v, tier, pos) in w.items():
            total += 1
            gh, gv, gt, gpos = g[leg]
            if (gh, gv, gt) == (h, v, tier):
                same += 1
                worst = max(worst, float(np.abs(np.array(gpos) - np.array(pos)).max()))
    return same, total, worst


@pytest.fixture(scope="module")
def recorded():
    return load()


def test_recorded_trots_get_the_same_selections(robot, recorded) -> None:
    for seq, want in zip(recorded["sequences"], recorded["expected"], strict=True):
        same, total, worst = _compare(replay_sequence(SwingPlanner(robot), seq), want)
        assert total > 150
        assert same >= 0.98 * total, f"{same} of {total} selections as recorded"
        assert worst < 1e-3, f"trajectories of the same selections differ by {worst * 1e3:.2f} mm"


@pytest.mark.parametrize("case", BENCH_CASES)
def test_bench_cases_get_the_same_selections(robot, recorded, case: str) -> None:
    same, total, worst = _compare(
        replay_bench_case(SwingPlanner(robot), case), recorded["expected_bench"][case]
    )
    assert same >= 0.98 * total, f"{case}: {same} of {total} selections as recorded"
    assert worst < 1e-3
