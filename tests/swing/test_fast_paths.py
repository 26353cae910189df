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
