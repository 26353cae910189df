"""The command line: exit codes and one-line errors for bad input."""

from __future__ import annotations

import json

import pytest

from server.cli import main


def test_terrains_lists_names(capsys) -> None:
    assert main(["terrains"]) == 0
    out = capsys.readouterr().out
    for name in ("flat", "stairs", "stones", "clutter", "under-table", "slope", "rough"):
        assert name in out


@pytest.mark.parametrize(
    ("argv", "needle"),
    [
        (["run", "no-such-maneuver"], "no maneuver named 'no-such-maneuver'"),
        (["run", "stand", "--push", "1.0:0,150"], "--push '1.0:0,150': force needs three components"),
        (["run", "stand", "--push", "x:0,1,0"], "time 'x' is not a number"),
        (["run", "stand", "--terrain", "moon"], "--terrain 'moon': unknown terrain"),
        (["run", "stand", "--robot", "atlas"], "robot 'atlas': no such robot description"),
        (["validate", "missing/dir/x.yaml"], "no such file: missing/dir/x.yaml"),
        (["walk", "--terrain", "stairs", "--maps", "lidar"], "--maps 'lidar': one of sensor, truth, off"),
        (["walk", "--terrain", "stairs", "--speed", "1.0"], "--speed 1.0 m/s is outside [0.2, 0.5] m/s"),
        (["walk", "--vx", "1.0", "--speed", "1.0"], "--speed: only on a terrain"),
        (
            ["walk", "--terrain", "stairs", "--descend-backward"],
            "--descend-backward: only walking to a --goal",
        ),
        (
            ["walk", "--terrain", "stairs", "--goal", "6,0", "--descend-backward", "--descend-forward"],
            "--descend-forward: not with --descend-backward",
        ),
        (
            ["walk", "--terrain", "stairs", "--terrain-pipeline", "modes"],
            "--terrain-pipeline 'modes': removed",
        ),
        (
            ["walk", "--trace", "t.csv", "--trace-every", "0.001"],
            "--trace-every 0.001 s: must be at least 0.002",
        ),
        (["walk", "--trace", "t.csv", "--trace-every", "nan"], "--trace-every nan s: must be at least 0.002"),
        (["walk", "--trace-every", "0.05"], "--trace-every: only with --trace FILE"),
        (["walk", "--trace", "no/such/dir/t.csv"], "--trace no/such/dir/t.csv: no such directory"),
    ],
)
def test_bad_input_is_one_line_and_exit_2(argv, needle, capsys) -> None:
    assert main(argv) == 2
    err = capsys.readouterr().err.strip()
    assert needle in err
    assert len(err.splitlines()) == 1
    assert "Traceback" not in err


def test_robot_description_naming_a_missing_joint(tmp_path, capsys) -> None:
    from planning.robot import load_robot

    spot = load_robot("spot")
    (tmp_path / "spot.xml").write_text(spot.mjcf_xml)
    text = (spot.mjcf_path.parent / "spot.yaml").read_text().replace("RR_kn", "RR_knee_joint")
    (tmp_path / "bad.yaml").write_text(text)
    assert main(["run", "stand", "--robot", str(tmp_path / "bad.yaml")]) == 2
    err = capsys.readouterr().err.strip()
    assert "legs.RR.joints: joint 'RR_knee_joint' is not in spot.xml" in err
    assert len(err.splitlines()) == 1


def test_validate_shipped_maneuver(capsys) -> None:
    assert main(["validate", "bow"]) == 0
    out = capsys.readouterr()
    assert "bow: valid" in out.out and "physics check: succeeded; 6.0 s simulated" in out.err
    assert main(["validate", "--no-physics", "bow"]) == 0
    out = capsys.readouterr()
    assert "bow: valid" in out.out and "physics" not in out.err


@pytest.mark.sim
def test_run_writes_report_and_exit_codes(tmp_path, capsys) -> None:
    out = tmp_path / "out.json"
    assert main(["run", "stand", "--duration", "2", "--push", "1.0:0,150,0:0.1", "--report", str(out)]) == 0
    rep = json.loads(out.read_text())
    for key in (
        "maneuver",
        "mode",
        "terrain",
        "duration_s",
        "success",
        "fell",
        "fall_time_s",
        "failure_reason",
        "final_pose_error",
        "touchdowns",
        "foot_placement_error_m",
        "no_step_touchdowns",
        "body_collisions",
        "velocity_tracking_rms",
        "solver",
        "timing",
    ):
        assert key in rep, key
    assert rep["success"] is True
    assert main(["run", "stand", "--duration", "2", "--push", "0.5:0,3000,0:0.1"]) == 1


def test_walk_maps_truth_writes_the_navigator_section(tmp_path, capsys) -> None:
    """`walk --terrain slope --maps truth` walks on the scene's own maps: the report carries the terrain pipeline's
    counters (no sensor scans needed, maps rebuilt around the body)."""
    out = tmp_path / "r.json"
    code = main(
        [
            "walk",
            "--terrain",
            "slope",
            "--vx",
            "0.4",
            "--duration",
            "2",
            "--maps",
            "truth",
            "--report",
            str(out),
        ]
    )
    r = json.loads(out.read_text())
    assert code == 0 and not r["fell"]
    assert r["navigator"]["scans"] >= 15  # 10 Hz for 2 s
    assert "perception p50" not in capsys.readouterr().out  # the scene's maps: no scans to time


def test_walk_summary_gives_the_perception_and_step_qp_times() -> None:
    from server.cli import _summary

    report = {
        "mode": "walk", "terrain": "stones", "success": True, "failure_reason": None, "duration_s": 22.0,
        "timing": {"wall_s": 44.0, "rtf": 0.5}, "final_pose_error": {"position_m": 0.03, "yaw_rad": 0.01},
        "stages": {"perception": {"p50_ms": 31.04, "p99_ms": 38.5}},
        "navigator": {"cloud_points_p50": 10248, "step_qp_solves": 2001, "step_qp_ms_p50": 7.162,
                      "step_qp_bare_solver_ms_p50": 3.123},
    }  # fmt: skip
    line = _summary(report)
    assert "perception p50 31.0 ms (10248 points a scan)" in line
    assert "step QP 2001 replans, p50 7.16 ms (bare OSQP 3.12 ms)" in line
    assert "in flight" not in line
    rms = {"vx": 0.1, "vy": 0.02, "yaw_rate": 0.05}
    report |= {"mean_velocity": {"vx": 2.3, "vy": 0.0, "yaw_rate": 0.0}, "velocity_tracking_rms": rms}
    assert "; in flight 3.1 % of the time" in _summary(report | {"flight_fraction": 0.0312})
    fell = report | {"success": False, "failure_reason": "fell: FL_lleg touched the world at t=10.77 s",
                     "fall_contact": {"part": "FL_lleg", "touched": "terrain_box_platform",
                                      "point_m": [3.4512, -0.1, 0.1204]}}  # fmt: skip
    assert (
        "FAILED (fell: FL_lleg touched the world at t=10.77 s) on terrain_box_platform at (3.45, -0.10, 0.12) m"
        in (_summary(fell))
    )


def test_walk_notes_when_the_terrain_speed_caps_the_command(capsys) -> None:
    """A steered terrain walk asked faster than its terrain speed says so, and how far --speed goes there."""
    argv = ["walk", "--terrain", "slope", "--maps", "truth", "--vx", "1.0", "--duration", "0.02"]
    main(argv)
    assert (
        "note: on slope the terrain speed caps --vx/--vy at 0.5 m/s; --speed up to 1.0"
        in capsys.readouterr().err
    )
    main([*argv, "--speed", "1.0"])
    assert "note:" not in capsys.readouterr().err


def test_walk_trace_gives_a_row_per_leg_per_sample(tmp_path, capsys) -> None:
    """`walk --trace FILE` writes the per-leg trace as CSV: its header, four rows (one per leg) each sample, the
    phases and the swing plans where the legs swing, and on a terrain the foothold chosen for each leg's next
    touchdown with the region under it."""
    import csv

    from planning.sim.trace import TRACE_COLUMNS

    path = tmp_path / "trace.csv"
    argv = ["walk", "--terrain", "slope", "--maps", "truth", "--vx", "0.4", "--duration", "1.0"]
    assert main([*argv, "--trace", str(path), "--trace-every", "0.05"]) == 0
    assert "trace: " in capsys.readouterr().err
    with path.open() as f:
        rows = list(csv.DictReader(f))
    assert tuple(rows[0].keys()) == TRACE_COLUMNS
    times = sorted({float(r["t_s"]) for r in rows})
    assert 19 <= len(times) <= 22  # every 0.05 s over 1 s
    assert len(rows) == 4 * len(times)
    assert all(
        sorted(r["leg"] for r in rows if float(r["t_s"]) == t) == ["FL", "FR", "RL", "RR"] for t in times
    )
    assert {r["phase"] for r in rows} <= {"stance", "swing", "late"}
    # a swing's plan is made on the swing planner's first replan after lift-off: a sample at the lift-off tick
    # itself has none yet
    swinging = [r for r in rows if r["phase"] == "swing"]
    planned = [r for r in swinging if r["target_x"]]
    assert len(planned) >= 0.7 * len(swinging) > 0
    assert all(r["tier"] and r["horizontal_policy"] and r["vertical_policy"] for r in planned)
    assert all(r["target_x"] == "" for r in rows if r["phase"] == "stance")
    chosen = [r for r in rows if r["chosen_x"]]
    assert chosen and all(r["region"] != "" and r["in_inset"] in ("0", "1") for r in chosen)
    assert all(r["facing"] == "forward" for r in rows)
    # the body walked forward (x grows) along the trace
    x = [float(r["body_x"]) for r in rows if r["leg"] == "FL"]
    assert x[-1] > x[0] + 0.1
