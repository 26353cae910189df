"""clip_scalar: np.clip's value on one number, bit for bit."""

from __future__ import annotations

import itertools

import numpy as np
from hypothesis import given
from hypothesis import strategies as st

from planning.geometry import clip_scalar

_SPECIAL = [-np.inf, -2.0, -1.0, -1e-300, -0.0, 0.0, 5e-324, 1e-300, 0.5, 1.0, 2.0, np.inf, np.nan]


def _bits(v: object) -> bytes:
    return np.float64(v).tobytes()  # type: ignore[arg-type]


def test_clip_scalar_equals_np_clip_on_special_values() -> None:
    # signed zeros, infinities, NaN (value or bound) and crossed bounds (lo > hi gives hi)
    for x, lo, hi in itertools.product(_SPECIAL, repeat=3):
        for v in (float(x), np.float64(x)):
            assert _bits(clip_scalar(v, lo, hi)) == _bits(np.clip(v, lo, hi)), (x, lo, hi)


@given(st.floats(), st.floats(allow_nan=False), st.floats(allow_nan=False))
def test_clip_scalar_equals_np_clip(x: float, lo: float, hi: float) -> None:
    assert _bits(clip_scalar(x, lo, hi)) == _bits(np.clip(x, lo, hi))
