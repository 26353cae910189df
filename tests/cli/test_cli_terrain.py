"""--terrain on the command line: every bad form is a one-line error (exit 2) naming the key or value."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from server.cli import main


def test_terrains_lists_parameters_with_ranges(capsys) -> None:
    assert main(["terrains", "--params"]) == 0
    out = capsys.readouterr().out
    assert "mixed" in out and "riser_m (0.02–0.3 m, default 0.15)" in out and "railings (default true)" in out


@pytest.mark.parametrize(
    ("args", "needle"),
    [
        (
            ["--terrain", "stairs:riser=0.18"],
            "--terrain 'stairs:riser=0.18': stairs: unknown parameter 'riser'",
        ),
        (["--terrain", "stairs:riser_m=0.5"], "stairs.riser_m=0.5: outside the allowed range 0.02–0.3 m"),
        (["--terrain", "stones:gap_m=0.3..0.1"], "stones.gap_m=0.3..0.1: min is above max"),
        (["--terrain", "nowhere/hm.npy:cell_m=0.05"], "nowhere/hm.npy: no such file"),
        (["--terrain", "scene.stl"], "unknown kind '.stl'"),
        (["--terrain", "clutter", "--seed", "-3"], "--seed -3: must be within 0 to 2^32 - 1"),
    ],
)
def test_bad_terrains_exit_2_with_one_line(args: list[str], needle: str, capsys) -> None:
    for cmd in (["walk", "--vx", "0.3"], ["run", "stand"]):
        assert main([*cmd, *args]) == 2
        err = capsys.readouterr().err.strip()
        assert needle in err and len(err.splitlines()) == 1, err


def test_a_heightmap_without_a_cell_size_says_how_to_give_one(tmp_path: Path, capsys) -> None:
    np.save(tmp_path / "hm.npy", np.zeros((5, 5)))
    assert main(["walk", "--vx", "0.3", "--terrain", str(tmp_path / "hm.npy")]) == 2
    err = capsys.readouterr().err
    assert (
        "a heightmap needs cell_m" in err
        and "hm.npy:cell_m=0.05, or cell_m: 0.05 in hm.yaml beside it" in err
    )
