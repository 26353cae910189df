"""Potential step paths: families, and screening against reach, self-collision, no-step and timing."""

from __future__ import annotations

import numpy as np
import pytest
from _steps_common import StripMaps, robot, walking_reference

from planning.steps import Constraints, Octagon, PathBatch, potential_step_paths, screen_paths


@pytest.mark.parametrize("n", [25, 100])
def test_families_and_count(n: int) -> None:
    ref, state, _ = walking_reference("trot", (0.5, 0.0, 0.0), v_state=(0.5, 0.2))
    paths = potential_step_paths(ref, state, robot(), n=n)
    assert 2 <= len(paths) <= n
    assert paths[0].kind == "reference" and np.array_equal(paths[0].p_world_touchdown, ref.p_world_touchdown)
    kinds = {p.kind for p in paths}
    assert {"clamped", "push", "push_lateral", "timing", "template", "offset", "footprint"} <= kinds
    assert len(paths) >= 0.7 * n  # a normal walk keeps most candidates
    assert all(np.array_equal(p.leg, ref.leg) for p in paths)


@pytest.mark.parametrize("gait", ["trot", "walk", "pace", "bound"])
def test_every_kept_path_satisfies_the_constraints(gait: str) -> None:
    ref, state, _ = walking_reference(gait, (0.4, 0.1, 0.3), v_state=(0.2, -0.3))
    maps = StripMaps(x0=0.45, half_width_m=0.06)
    paths = potential_step_paths(ref, state, robot(), maps=maps, n=40)
    assert len(paths) >= 2
    scr = screen_paths(PathBatch.of(paths), ref, state, robot(), maps)
    assert np.all(scr.total == 0.0) and all(p.violation == 0.0 for p in paths)
    for p in paths:
        assert not np.any(np.abs(p.p_world_touchdown[:, 0] - 0.45) < 0.06)


def test_out_of_reach_reference_is_dropped_and_clamped_kept() -> None:
    # Shoved sideways: the reference's capture-point step lies beyond the lateral reach.
    ref, state, _ = walking_reference("trot", (0.3, 0.0, 0.0), v_state=(0.3, 0.9))
    scr = screen_paths(PathBatch.of([ref]), ref, state, robot())
    assert scr.reach[0] > 0.0
    kinds = [p.kind for p in potential_step_paths(ref, state, robot(), n=25)]
    assert "reference" not in kinds and "clamped" in kinds


def test_reach_octagon() -> None:
    c = Constraints()
    o = Octagon.of(robot(), c)
    assert o.rx <= c.reach_x_m and o.ry <= c.reach_y_m
    inside = np.array([[0.0, 0.0], [o.rx * 0.99, 0.0], [0.0, -o.ry * 0.99]])
    outside = np.array([[o.rx * 1.01, 0.0], [o.rx * 0.95, o.ry * 0.95], [0.0, 1.0]])
    assert np.all(o.violation(inside) == 0.0) and np.all(o.violation(outside) > 0.0)
    pts = np.random.default_rng(0).uniform(-1, 1, (200, 2))
    assert np.all(o.violation(o.clamp(pts)) < 1e-12)
    small = o.violation(pts) == 0.0
    assert np.allclose(o.clamp(pts)[small], pts[small])


def test_keep_out_and_midline_catch_a_foot_placed_on_another() -> None:
    ref, state, _ = walking_reference("trot", (0.0, 0.0, 0.0))
    bad_xy = ref.p_world_touchdown.copy()
    k = int(np.flatnonzero(ref.leg == 0)[0])  # FL's first touchdown onto FR's place
    bad_xy[k, :2] = state.p_world_feet[1, :2] + [0.0, 0.05]
    bad = ref.with_touchdowns(bad_xy, "offset")
    scr = screen_paths(PathBatch.of([ref, bad]), ref, state, robot())
    assert scr.collision[0] == 0.0 and scr.collision[1] > 0.0


def test_timing_catches_a_touchdown_in_the_past_and_too_fast_a_swing() -> None:
    ref, state, _ = walking_reference("trot", (0.5, 0.0, 0.0), t0=0.0)
    early = ref.with_touchdowns(ref.p_world_touchdown, "timing", t_shift=-0.3)
    far_xy = ref.p_world_touchdown.copy()
    far_xy[0, :2] += [2.0, 0.0]
    far = ref.with_touchdowns(far_xy, "offset")
    scr = screen_paths(PathBatch.of([ref, early, far]), ref, state, robot())
    assert scr.timing[0] == 0.0 and scr.timing[1] > 0.0 and scr.timing[2] > 0.0


def test_when_nothing_is_feasible_all_are_kept_with_their_violation() -> None:
    ref, state, _ = walking_reference("trot", (0.5, 0.0, 0.0))
    maps = StripMaps(x0=0.0, half_width_m=50.0)  # no place to step
    paths = potential_step_paths(ref, state, robot(), maps=maps, n=25)
    assert len(paths) == 25 and all(p.violation > 0 for p in paths)


def test_standing_returns_the_reference_alone_and_n_is_checked() -> None:
    ref, state, _ = walking_reference("stand", (0.0, 0.0, 0.0))
    assert potential_step_paths(ref, state, robot()) == [ref]
    with pytest.raises(ValueError, match="n"):
        potential_step_paths(ref, state, robot(), n=1)


def test_works_with_terrain_maps_no_step_and_heights() -> None:
    from planning.terrain.maps import maps_from_grids

    res = 0.02
    xs = -1.0 + np.arange(150) * res
    ground = np.where(xs[:, None] > 0.7, 0.1, 0.0) * np.ones((1, 100))  # a 10 cm step up at x = 0.7
    gap = (np.abs(xs - 0.45) < 0.07)[:, None] * np.ones((1, 100), bool)  # a gap a foot must not enter
    maps = maps_from_grids((-1.0, -1.0), res, ground, gap)
    ref, state, _ = walking_reference("trot", (0.5, 0.0, 0.0))
    paths = potential_step_paths(ref, state, robot(), maps=maps, n=25)
    assert len(paths) >= 2 and all(p.violation == 0.0 for p in paths)
    for p in paths:
        x, z = p.p_world_touchdown[:, 0], p.p_world_touchdown[:, 2]
        assert not np.any(np.asarray(maps.no_step(x, p.p_world_touchdown[:, 1])))
        assert np.allclose(z, np.where(x > 0.71, 0.1, np.where(x < 0.69, 0.0, z)))


def test_avoid_variants_from_one_map_evaluation_equal_each_variant_alone() -> None:
    """_avoid_all (the three off-no-step variants from one evaluation of the map) gives what _avoid gives for each
    variant alone: on a strip that catches some touchdowns, one it catches whole (no sample allowed), and none."""
    from planning.steps.potential import _avoid, _avoid_all

    rng = np.random.default_rng(7)
    for x0, hw in ((0.3, 0.05), (0.0, 5.0), (9.0, 0.05)):
        maps = StripMaps(x0, hw)
        for _ in range(20):
            xy = rng.uniform(-0.2, 0.8, (8, 2))
            yaw = rng.uniform(-np.pi, np.pi, 8)
            got = _avoid_all(xy, yaw, maps)
            for out, forward in zip(got, (None, 1.0, -1.0), strict=True):
                assert np.array_equal(out, _avoid(xy, yaw, maps, forward))
