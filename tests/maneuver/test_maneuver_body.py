"""The body reference: through every keyframe, C1, no overshoot, holds before and after, follows the feet."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from planning.maneuver import BodyReference, find_maneuver, load_maneuver, parse_maneuver, rotation_from_rpy
from planning.robot import load_robot

ROBOT = load_robot("spot")
H = ROBOT.standing_height_m


def _ref(body: list[dict], duration: float = 6.0) -> BodyReference:
    m = {"format": "footfall/maneuver@1", "name": "keys", "duration": duration, "body": body}
    return BodyReference.from_maneuver(parse_maneuver(m), ROBOT)


keyframe_lists = st.lists(
    st.tuples(
        st.floats(0.2, 1.5),  # gap to the previous keyframe, s
        st.lists(st.floats(-0.1, 0.1), min_size=2, max_size=2),
        st.floats(0.40, 0.58),
        st.lists(st.floats(-20, 20), min_size=3, max_size=3),
        st.floats(0.0, 5.0),
    ),
    min_size=1,
    max_size=6,
).map(
    lambda rows: [
        {
            "t": round(sum(r[0] for r in rows[: i + 1]), 6),
            "position": [*r[1], r[2]],
            "rpy": r[3],
            "weight": r[4],
        }
        for i, r in enumerate(rows)
    ]
)


@settings(max_examples=60, deadline=None)
@given(keyframe_lists)
def test_reference_hits_every_keyframe_and_holds_the_ends(body: list[dict]) -> None:
    ref = _ref(body, duration=60.0)
    p, v, rpy, w = ref.sample(0.0)
    np.testing.assert_allclose(p, [0, 0, H], atol=1e-12)
    np.testing.assert_allclose(rpy, 0.0, atol=1e-12)
    for k in body:
        p, _, rpy, _ = ref.sample(k["t"])
        np.testing.assert_allclose(p, k["position"], atol=1e-9)
        np.testing.assert_allclose(rpy, np.radians(k["rpy"]), atol=1e-9)
        assert ref.weight(k["t"]) == pytest.approx(k["weight"])
    p, v, rpy, w = ref.sample(body[-1]["t"] + 3.0)
    np.testing.assert_allclose(p, body[-1]["position"], atol=1e-12)
    assert np.all(v == 0) and np.all(w == 0)


@settings(max_examples=40, deadline=None)
@given(keyframe_lists)
def test_reference_is_c1_and_its_velocity_is_its_derivative(body: list[dict]) -> None:
    ref = _ref(body, duration=60.0)
    eps = 1e-6
    knots = [0.0] + [k["t"] for k in body]
    for t in np.linspace(0.0, knots[-1] + 0.5, 97):
        pose_a, _ = ref.pose_and_rate(float(t) - eps)
        pose_b, _ = ref.pose_and_rate(float(t) + eps)
        _, rate = ref.pose_and_rate(float(t))
        np.testing.assert_allclose((pose_b - pose_a) / (2 * eps), rate, atol=1e-4)
    for t in knots:  # velocity continuous across each knot
        _, ra = ref.pose_and_rate(t - 1e-9)
        _, rb = ref.pose_and_rate(t + 1e-9)
        np.testing.assert_allclose(ra, rb, atol=1e-5)


@settings(max_examples=40, deadline=None)
@given(keyframe_lists)
def test_reference_never_overshoots_its_knots(body: list[dict]) -> None:
    ref = _ref(body, duration=60.0)
    for k in range(len(ref.t_knot) - 1):
        lo = np.minimum(ref.pose_knot[k], ref.pose_knot[k + 1]) - 1e-9
        hi = np.maximum(ref.pose_knot[k], ref.pose_knot[k + 1]) + 1e-9
        for t in np.linspace(ref.t_knot[k], ref.t_knot[k + 1], 11):
            pose, _ = ref.pose_and_rate(float(t))
            assert np.all(pose >= lo) and np.all(pose <= hi)


def test_crouch_does_not_dip_below_its_lowest_keyframe() -> None:
    ref = BodyReference.from_maneuver(load_maneuver(find_maneuver("crouch")), ROBOT)
    heights = [ref.sample(float(t))[0][2] for t in np.linspace(0, 6, 601)]
    assert min(heights) == pytest.approx(0.40, abs=1e-9)
    assert max(heights) == pytest.approx(H, abs=1e-9)


def test_omega_matches_the_rotation_derivative() -> None:
    ref = _ref(
        [
            {"t": 1.0, "position": [0, 0, 0.5], "rpy": [10, 15, 30]},
            {"t": 2.0, "position": [0, 0, 0.5], "rpy": [-10, 5, -20]},
        ]
    )
    eps = 1e-6
    for t in (0.3, 0.7, 1.4, 1.8):
        _, _, rpy, omega = ref.sample(t)
        R = rotation_from_rpy(rpy)
        dR = (rotation_from_rpy(ref.sample(t + eps)[2]) - rotation_from_rpy(ref.sample(t - eps)[2])) / (
            2 * eps
        )
        W = dR @ R.T  # skew(omega_world)
        np.testing.assert_allclose([W[2, 1], W[0, 2], W[1, 0]], omega, atol=1e-5)


def test_pitch_positive_lowers_the_nose() -> None:
    R = rotation_from_rpy(np.radians([0.0, 20.0, 0.0]))
    nose = R @ [1.0, 0.0, 0.0]
    assert nose[2] < 0


def test_keyframe_at_zero_replaces_the_start_pose() -> None:
    ref = _ref([{"t": 0.0, "position": [0, 0, 0.45]}, {"t": 1.0, "position": [0, 0, 0.5]}])
    assert ref.sample(0.0)[0][2] == pytest.approx(0.45)


def test_without_keyframes_the_body_follows_the_feet_of_a_trot(mk) -> None:
    m = parse_maneuver(
        mk(
            duration=4.0,
            gaits=[
                {"gait": "trot", "from": 0.5, "to": 3.5, "cycle": 0.5, "duty": 0.6, "step": [0.1, 0.0, 10.0]}
            ],
        )
    )
    ref = BodyReference.from_maneuver(m, ROBOT)
    assert not ref.from_keyframes
    xs = [ref.sample(float(t))[0][0] for t in np.linspace(0, 4, 81)]
    assert np.all(np.diff(xs) >= -1e-9)  # moves forward without going back
    p, v, rpy, _ = ref.sample(4.0)
    assert rpy[2] == pytest.approx(math.radians(60.0), abs=1e-6)  # 6 cycles × 10°
    assert p[2] == pytest.approx(H)
    chord = 0.1 * math.sin(math.radians(30)) / math.sin(math.radians(5))  # six 0.1 m steps turning 10° each
    assert np.linalg.norm(p[:2]) == pytest.approx(chord, abs=1e-6)
    assert np.all(v == 0)
    assert ref.weight(2.0) == 1.0


def test_without_anything_the_body_stands(mk) -> None:
    ref = BodyReference.from_maneuver(parse_maneuver(mk()), ROBOT)
    p, v, rpy, w = ref.sample(2.0)
    np.testing.assert_allclose(p, [0, 0, H])
    assert not np.any(v) and not np.any(rpy) and not np.any(w)
