"""benchmarks.loop_profile: every part of the loop is charged, and the parts add up to the run's CPU time."""

from __future__ import annotations

import pytest

from benchmarks.loop_profile import profile_walk


@pytest.mark.parametrize("walk", ["flat", "stairs"])
def test_the_loop_profile_charges_every_stage_and_adds_up(walk: str) -> None:
    out = profile_walk(walk, duration_s=0.3)
    parts = out["cpu_ms_per_simulated_s"]
    expected = {"step_plan", "swing", "balance", "actuate", "read_state", "mujoco_step", "monitors", "other"}
    expected |= {"centroidal", "centroidal.osqp"} if walk == "flat" else {"perception", "perception.maps"}
    assert expected <= set(parts), sorted(parts)
    assert abs(out["simulated_s"] - 0.3) < 0.01
    # the top-level parts (not the OSQP or perception sub-parts, already inside their stage) sum to the total
    top = sum(v for k, v in parts.items() if "." not in k)
    total = 1e3 * out["cpu_s"] / out["simulated_s"]
    assert top == pytest.approx(total, rel=0.05, abs=5.0)
    assert all(v >= 0.0 for v in parts.values())
