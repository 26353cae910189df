"""benchmarks.centroidal_walk --peer: the walk and a peer command in one run; the peer's own loop figure is read from
its last line, the ratio is the walk's CPU real-time factor over the peer's, and each stage is charged."""

from __future__ import annotations

import shlex
import sys

import pytest

from benchmarks.centroidal_walk import beside_peer


def test_beside_peer_reads_the_peers_loop_figure_and_reports_the_ratio() -> None:
    peer = f"{shlex.quote(sys.executable)} -c \"print('peer loop: simulated 5.0 s, sim_per_cpu 0.500')\""
    out = beside_peer(peer, 5.0, vx=0.5, duration_s=0.4)
    assert out["peer_real_time_factor_cpu"] == pytest.approx(0.5)
    assert out["peer_timed"] == "its loop (own timer)"
    rtf = min(out["footfall_real_time_factor_cpu"])
    assert rtf > 0.0
    assert out["ratio_cpu"] == pytest.approx(rtf / 0.5, abs=0.01)
    parts = out["stage_cpu_ms_per_simulated_s"]
    assert {"centroidal", "centroidal.osqp", "step_plan", "swing", "actuate"} <= set(parts)
    assert out["stage_over_bare_osqp"]["centroidal"] > 1.0  # the stage's Python work is on top of OSQP's


def test_beside_peer_without_the_loop_line_times_the_whole_child() -> None:
    out = beside_peer(f"{shlex.quote(sys.executable)} -c pass", 5.0, vx=0.5, duration_s=0.3)
    assert out["peer_timed"] == "whole child process"
    assert out["peer"]["returncode"] == 0
    assert out["peer_real_time_factor_cpu"] == out["peer"]["real_time_factor_cpu"]


def test_stage_rates_can_be_set_for_an_experiment_and_bad_names_are_refused() -> None:
    from benchmarks.centroidal_walk import _session

    session = _session(0.5, 0.0, 0.0, 0.2, {"step_plan": 50.0, "swing": 166.7})
    rates = {st.name: st.rate_hz for st in session.loop.stages}
    assert rates["step_plan"] == 50.0 and rates["swing"] == 166.7
    with pytest.raises(ValueError, match="no loop stage 'stepplan'"):
        _session(0.5, 0.0, 0.0, 0.2, {"stepplan": 50.0})
    with pytest.raises(ValueError, match="above 0 Hz"):
        _session(0.5, 0.0, 0.0, 0.2, {"swing": 0.0})
