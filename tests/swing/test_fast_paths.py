"""The planner's fast paths compute exactly what the NumPy calls they replace compute (bit for bit)."""

from __future__ import annotations

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from planning.swing.planner import _linspace
from planning.swing.types import Box, BoxGround

times = st.floats(-1e3, 1e3, allow_nan=False)


@settings(max_examples=300, deadline=None)
@given(t0=times, t1=times, n=st.integers(2, 40))
def test_linspace_is_bit_identical_to_numpy(t0: float, t1: float, n: int) -> None:
    got = _linspace(t0, t1, np.arange(n, dtype=float))
    want = np.linspace(t0, t1, n)
    assert got.tobytes() == want.tobytes()


def test_box_ground_takes_the_highest_box_and_the_base_elsewhere() -> None:
    ground = BoxGround([Box(0.0, 1.0, 0.0, 1.0, 0.2), Box(0.5, 2.0, 0.5, 2.0, 0.3)], base_m=-0.1)
    x = np.array([0.25, 0.75, 1.5, 3.0])
    y = np.array([0.25, 0.75, 1.5, 3.0])
    assert ground(x, y).tolist() == [0.2, 0.3, 0.3, -0.1]


def test_the_float_knees_are_the_vectorized_ones() -> None:
    """The knee check's per-sample float IK (Analyzer._knees_few) finds the knees the vectorized IK finds, at the
    same samples, on a crossing where the foot passes another leg (bodies yawed and moving)."""
    from planning.robot import load_robot
    from planning.swing.bench import _case
    from planning.swing.planner import SwingPlanner
    from planning.swing.policies import cubic
    from planning.swing.types import BodyMotion, SwingRequest

    robot = load_robot("spot")
    planner = SwingPlanner(robot)
    req, ground, stance, _ = _case("crossing")
    compared = 0
    for yaw in (0.0, 0.4, -0.7):
        c, s = np.cos(yaw), np.sin(yaw)
        R = np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])
        body = BodyMotion(0.1, np.array([0.05, 0.0, 0.52]), R, np.array([0.3, 0.1, 0.0]), 0.5)
        r = SwingRequest(0, req.p_world_foot, np.array([0.8, 0.0, 0.6]), req.p_touchdown, req.t_touchdown)
        st_ = planner._checked_stance(stance)
        fixed = planner._stance_obstacles(st_, body, 0.1, c, s)
        prob = planner._problem(0.1, r, ground, fixed, body, {}, c, s)
        an = planner.analyzer
        v = an.analyze(prob, cubic(prob.ctx), 1.0)
        v.knee_idx = np.arange(1, len(prob.ts) - 1)  # every interior sample
        for zs in (prob.zs_aggressive, an.gentlest(prob)[1]):
            kf, kept_f = an._knees_few(prob, v, zs)
            km, kept_m = an._knees_many(prob, v, zs)
            assert kf is not None and kept_m is not None
            assert np.array_equal(kept_f, kept_m)
            assert np.abs(kf - km).max() < 1e-6
            compared += len(kept_f)
    assert compared > 60


def test_sample_pair_is_sample_many_of_each() -> None:
    """The paths' x and y sampled together (one piece lookup; a Cubic path's two pieces without gathering) give
    each axis's sample_many, bit for bit."""
    from planning.swing._poly import sample_pair
    from planning.swing.policies import HORIZONTAL_POLICIES, LegCtx

    rng = np.random.default_rng(7)
    pairs = 0
    for _ in range(40):
        p0 = tuple(rng.normal(0.0, 0.2, 2).tolist())
        ctx = LegCtx(0.1, 0.1 + rng.uniform(0.1, 0.4), p0, tuple(rng.normal(0.0, 1.0, 2).tolist()),
                     tuple(rng.normal(0.0, 0.2, 2).tolist()), 4.0, 80.0, [], 0.03, 0.1, [])  # fmt: skip
        # beyond both ends, and the problem's own sample times (the last one on a Cubic path's tail)
        for ts in (np.linspace(ctx.t0 - 0.01, ctx.t_end + 0.05, 20), np.linspace(ctx.t0, ctx.t_end, 20)):
            for _, fn in HORIZONTAL_POLICIES:
                hp = fn(ctx)
                if hp is None:
                    continue
                hx, hy = sample_pair(hp.x, hp.y, ts)
                assert hx.tobytes() == hp.x.sample_many(ts).tobytes()
                assert hy.tobytes() == hp.y.sample_many(ts).tobytes()
                pairs += hp.x.breaks == hp.y.breaks
    assert pairs > 40


@settings(max_examples=100, deadline=None)
@given(
    yaw=st.floats(-3.2, 3.2),
    yaw_rate=st.sampled_from([0.0, 0.8, -1.5]),
    v=st.tuples(*[st.floats(-2.0, 2.0)] * 3),
    dts=st.tuples(*[st.floats(-0.1, 0.5)] * 3),
    leg=st.integers(0, 3),
)
def test_the_float_hips_are_hip_world_many(
    yaw: float, yaw_rate: float, v: tuple[float, float, float], dts: tuple[float, float, float], leg: int
) -> None:
    """SwingPlanner._hips_at (Python floats) places the hips where BodyMotion.hip_world_many does, to rounding."""
    from planning.robot import load_robot
    from planning.swing.planner import SwingPlanner
    from planning.swing.types import BodyMotion

    robot = load_robot("spot")
    c, s = np.cos(yaw), np.sin(yaw)
    R = np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])
    body = BodyMotion(0.3, np.array([1.0, -0.5, 0.52]), R, np.array(v), yaw_rate)
    times = tuple(0.3 + dt for dt in dts)
    got = SwingPlanner(robot)._hips_at(body, times, leg)
    want = body.hip_world_many(np.array(times), robot.p_body_hip[leg])
    assert np.abs(got - want).max() < 1e-12


def test_the_event_driven_selection_reuses_only_while_its_inputs_hold() -> None:
    """A replan from where the last plan put the foot reuses its selection (the same policies and trajectory the
    full analysis gives); a moved target, or the full analysis turned off, runs the full selection."""
    import dataclasses

    from planning.robot import load_robot
    from planning.swing.params import SwingParams
    from planning.swing.planner import SwingPlanner
    from planning.swing.types import SwingRequest

    robot = load_robot("spot")
    full = SwingPlanner(robot, dataclasses.replace(SwingParams(), reuse_selection_s=0.0))
    event = SwingPlanner(robot)
    p0, p1, t1 = np.array([0.3, 0.165, 0.0]), np.array([0.45, 0.165, 0.0]), 0.3
    first = event.plan(0.0, [SwingRequest(0, p0, np.zeros(3), p1, t1)])[0]
    full.plan(0.0, [SwingRequest(0, p0, np.zeros(3), p1, t1)])
    for k in range(1, 6):
        t = 0.003 * k
        p, v, _ = first.sample(t)
        got = event.plan(t, [SwingRequest(0, p, v, p1, t1)])[0]
        want = full.plan(t, [SwingRequest(0, p, v, p1, t1)])[0]
        assert (got.horizontal_policy, got.vertical_policy, got.tier) == (
            want.horizontal_policy,
            want.vertical_policy,
            want.tier,
        )
        ts = np.linspace(t, t1, 7)
        assert np.allclose(got.positions(ts), want.positions(ts), atol=1e-9)
    assert event.reused == 5 and full.reused == 0
    p, v, _ = first.sample(0.018)
    event.plan(0.018, [SwingRequest(0, p, v, p1 + np.array([0.01, 0.0, 0.0]), t1)])
    assert event.reused == 5  # the target moved: the full selection


def test_a_completed_reuse_set_up_is_the_full_set_up() -> None:
    """The event-driven selection's set-up (_problem with full=False), completed by _complete when the reuse fails,
    gives the analysis what the full set-up gives: the same keep-outs on the route, aggressive samples and hips,
    and the same verdicts (the knee grid's ground then looked up by the analysis), beside a box and at a
    crossing, bodies yawed and moving."""
    from planning.robot import load_robot
    from planning.swing.bench import _case
    from planning.swing.planner import SwingPlanner
    from planning.swing.policies import HORIZONTAL_POLICIES
    from planning.swing.types import BodyMotion, SwingRequest

    robot = load_robot("spot")
    planner = SwingPlanner(robot)
    an = planner.analyzer
    analysed = 0
    for name in ("box", "crossing"):
        req, ground, stance, _ = _case(name)
        for yaw in (0.0, 0.4, -0.7):
            c, s = float(np.cos(yaw)), float(np.sin(yaw))
            R = np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])
            body = BodyMotion(0.1, np.array([0.05, 0.0, 0.52]), R, np.array([0.3, 0.1, 0.0]), 0.5)
            r = SwingRequest(0, req.p_world_foot, np.array([0.8, 0.0, 0.6]), req.p_touchdown, req.t_touchdown)
            fixed = planner._stance_obstacles(planner._checked_stance(stance), body, 0.1, c, s)
            want = planner._problem(0.1, r, ground, fixed, body, {}, c, s)
            got = planner._problem(0.1, r, ground, fixed, body, {}, c, s, full=False)
            assert got.zs_aggressive is None
            planner._complete(got, r)
            assert got.ctx.blocked == want.ctx.blocked
            assert got.zs_aggressive is not None and want.zs_aggressive is not None
            assert np.array_equal(got.zs_aggressive, want.zs_aggressive)
            assert np.array_equal(got.hips, want.hips)
            for _, fn in HORIZONTAL_POLICIES:
                hp = fn(want.ctx)
                if hp is None:
                    continue
                vw, vg = an.analyze(want, hp, 1.0), an.analyze(got, hp, 1.0)
                assert (vw.tier, vw.key, vw.blame, vw.knee_sev) == (vg.tier, vg.key, vg.blame, vg.knee_sev)
                analysed += 1
            assert got.g_knee_max == want.g_knee_max  # looked up by the analysis, the same highest ground
    assert analysed > 30


def test_the_split_terrain_lookups_give_the_combined_verdicts() -> None:
    """Once a candidate collided with the terrain, the analysis looks up the ground under the samples and the ring
    probes separately: the same tiers, keys and (where looked up) ground and ring probes as the one lookup, over
    boxes of several heights, with and without the endpoint zone, at several swing phases."""
    import dataclasses

    from planning.robot import load_robot
    from planning.swing.params import SwingParams
    from planning.swing.planner import SwingPlanner
    from planning.swing.policies import HORIZONTAL_POLICIES
    from planning.swing.types import BodyMotion, SwingRequest

    robot = load_robot("spot")
    ground = BoxGround(
        [
            Box(0.30, 0.36, 0.05, 0.30, 0.04),
            Box(0.40, 0.46, 0.10, 0.25, 0.10),
            Box(0.52, 0.70, -0.1, 0.4, 0.03),
        ]
    )
    stance = {
        1: np.array([0.35, -0.165, 0.0]),
        2: np.array([-0.25, 0.165, 0.0]),
        3: np.array([-0.25, -0.165, 0.0]),
    }
    body = BodyMotion(0.0, np.array([0.05, 0.0, 0.52]), np.eye(3))
    tiers = set()
    for zone in (None, 0.03):
        planner = SwingPlanner(robot, dataclasses.replace(SwingParams(), endpoint_zone_m=zone))
        an = planner.analyzer
        for x0, z0, vz0, target_z in (
            (0.20, 0.0, 0.0, 0.0),
            (0.25, 0.03, 0.5, 0.03),
            (0.33, 0.06, 0.0, 0.03),
        ):
            for t in (0.0, 0.1, 0.2):
                r = SwingRequest(
                    0,
                    np.array([x0, 0.165, z0]),
                    np.array([0.5, 0.0, vz0]),
                    np.array([0.56, 0.165, target_z]),
                    0.35,
                )
                fixed = planner._stance_obstacles(planner._checked_stance(stance), body, t, 1.0, 0.0)
                one = planner._problem(t, r, ground, fixed, body, {}, 1.0, 0.0)
                split = planner._problem(t, r, ground, fixed, body, {}, 1.0, 0.0)
                split.terrain_hit = True
                for _, fn in HORIZONTAL_POLICIES:
                    hp = fn(one.ctx)
                    if hp is None:
                        continue
                    one.terrain_hit = False
                    va, vb = an.analyze(one, hp, 1.0), an.analyze(split, hp, 1.0)
                    assert (va.tier, va.key, va.blame) == (vb.tier, vb.key, vb.blame)
                    if len(vb.g):
                        assert np.array_equal(va.g, vb.g)
                    if vb.ring_g is not None:
                        assert va.ring_g is not None and np.array_equal(va.ring_g, vb.ring_g)
                    tiers.add(va.tier.name)
    assert {"TERRAIN_COLLISION", "SUCCESS"} <= tiers, tiers
