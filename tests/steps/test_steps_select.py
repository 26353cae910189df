"""Selection by Eq. 1: zero for equal paths, weights steer between stable and accurate paths, lazy evaluation."""

from __future__ import annotations

import numpy as np
import pytest
from _steps_common import StripMaps, robot, walking_reference

from planning.steps import (
    SelectionParams,
    WeightPresets,
    Weights,
    potential_step_paths,
    score_components,
    score_path,
    score_paths,
    select_step_path,
)


@pytest.mark.parametrize("estimate", ["cof", "tracking"])
def test_equal_paths_score_zero(estimate: str) -> None:
    ref, state, _ = walking_reference("trot", (0.5, 0.1, 0.2), v_state=(0.1, 0.4))
    params = SelectionParams(estimate=estimate)  # type: ignore[arg-type]
    assert score_path(ref, ref, state, params=params) == 0.0
    copy = ref.with_touchdowns(ref.p_world_touchdown.copy(), "offset")
    moved = ref.with_touchdowns(ref.p_world_touchdown + [0.03, 0.0, 0.0], "offset")
    s = score_paths([copy, moved], ref, state, params=params)
    assert s[0] == 0.0 and s[1] > 0.0


def test_reference_wins_when_feasible() -> None:
    ref, state, _ = walking_reference("trot", (0.5, 0.0, 0.0))
    paths = potential_step_paths(ref, state, robot(), n=25)
    sel = select_step_path(ref, paths, state)
    assert sel.score == 0.0 and sel.path.kind in ("reference", "template", "push", "push_lateral")
    assert sel.scores.shape == (len(paths),) and np.all(sel.scores >= 0.0) and sel.feasible


def _pushed():
    """A robot shoved sideways while trotting: the reference (with its capture-point step) cannot be reached."""
    ref, state, _ = walking_reference("trot", (0.3, 0.0, 0.0), v_state=(0.3, 0.9))
    paths = potential_step_paths(ref, state, robot(), n=100)
    assert all(p.kind != "reference" for p in paths)  # infeasible, dropped
    return ref, state, paths


def test_weights_choose_between_stability_and_accuracy() -> None:
    # Two ways off the reference: nudge the first touchdown a little (accurate, but every later capture point
    # relative to that foot moves too), or the last touchdown more (less accurate, capture points barely move).
    ref, state, _ = walking_reference("trot", (0.5, 0.0, 0.0))
    early, late = ref.p_world_touchdown.copy(), ref.p_world_touchdown.copy()
    early[0, :2] += [0.02, 0.0]
    late[-1, :2] += [0.03, 0.0]
    paths = [ref.with_touchdowns(early, "offset"), ref.with_touchdowns(late, "offset")]
    placement, capture, _, _ = score_components(paths, ref, state)
    assert placement[0] < placement[1] and capture[1] < capture[0]
    assert select_step_path(ref, paths, state, Weights(q_p=1e3, q_r=1e-3)).index == 0  # most accurate
    assert select_step_path(ref, paths, state, Weights(q_p=1e-3, q_r=1e3)).index == 1  # most stable
    assert select_step_path(ref, paths, state, WeightPresets.PRECISE_FOOTING).index == 0
    assert select_step_path(ref, paths, state, WeightPresets.STABLE_BODY).index == 1


def test_extreme_weights_pick_the_component_minimum_among_generated_paths() -> None:
    ref, state, paths = _pushed()
    placement, capture, _, _ = score_components(paths, ref, state)
    assert select_step_path(ref, paths, state, Weights(q_p=1e4, q_r=1e-4)).index == int(np.argmin(placement))
    assert select_step_path(ref, paths, state, Weights(q_p=1e-4, q_r=1e4)).index == int(np.argmin(capture))
    sel = select_step_path(ref, paths, state, WeightPresets.DEFAULT)
    assert sel.index == int(np.argmin(placement + capture)) and sel.path.kind != "reference"


def test_lazy_selection_takes_the_first_below_threshold() -> None:
    ref, state, paths = _pushed()
    full = select_step_path(ref, paths, state)
    thr = float(np.quantile(full.scores, 0.5))
    lazy = select_step_path(ref, paths, state, params=SelectionParams(lazy_threshold=thr, lazy_chunk=4))
    assert lazy.score <= thr
    assert lazy.index == int(np.flatnonzero(full.scores <= thr)[0])
    assert lazy.n_evaluated < len(paths) and np.isnan(lazy.scores[-1])


def test_least_violating_wins_when_nothing_is_feasible() -> None:
    ref, state, _ = walking_reference("trot", (0.5, 0.0, 0.0))
    paths = potential_step_paths(ref, state, robot(), maps=StripMaps(0.0, 50.0), n=25)
    sel = select_step_path(ref, paths, state)
    assert not sel.feasible
    assert sel.path.violation == min(p.violation for p in paths)


def test_presets_by_name() -> None:
    assert WeightPresets.get("stable body") == WeightPresets.STABLE_BODY
    assert WeightPresets.get("precise_footing").q_p > WeightPresets.get("precise_footing").q_r
    with pytest.raises(ValueError, match="preset"):
        WeightPresets.get("wobbly")
    with pytest.raises(ValueError, match="q_r"):
        Weights(q_p=1.0, q_r=-1.0)
