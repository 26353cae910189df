"""The walk's per-leg trace (planning.sim.trace): sampling, flat ground without a terrain pipeline, its row cap."""

from __future__ import annotations

import pytest

from planning.sim import trace as T
from planning.sim.run import RunOptions, WalkCommand, WalkSession


def _session(every_s: float, duration_s: float) -> WalkSession:
    s = WalkSession(
        WalkCommand(0.3, 0.0, 0.0, "trot"), RunOptions(duration_s=duration_s), trace_every_s=every_s
    )
    s.run()
    return s


def test_flat_trace_has_no_terrain_columns() -> None:
    s = _session(0.02, 0.6)
    rows = s.trace.rows
    assert len(rows) % 4 == 0 and 28 <= len(rows) // 4 <= 32  # every 0.02 s over 0.6 s
    col = {name: k for k, name in enumerate(T.TRACE_COLUMNS)}
    assert all(r[col["facing"]] == "" and r[col["chosen_x"]] == "" and r[col["region"]] == "" for r in rows)
    assert {r[col["phase"]] for r in rows} >= {"stance", "swing"}
    # samples are every_s apart (the first at the first tick)
    ts = sorted({r[col["t_s"]] for r in rows})
    gaps = [b - a for a, b in zip(ts, ts[1:], strict=False)]
    assert all(0.0199 <= g <= 0.0221 for g in gaps)


def test_trace_stops_at_its_row_cap(monkeypatch) -> None:
    monkeypatch.setattr(T, "MAX_TRACE_ROWS", 40)
    s = _session(0.01, 0.3)
    assert len(s.trace.rows) == 40  # ten samples of four legs
    assert s.trace.dropped > 0 and s.trace.dropped % 4 == 0


@pytest.mark.parametrize("every", [0.0, 0.001, -1.0, float("inf"), float("nan")])
def test_a_bad_period_is_refused(every: float) -> None:
    assert T.check_trace_every(every) is not None
    with pytest.raises(ValueError, match="every_s"):
        T.LegTrace(None, None, every)
