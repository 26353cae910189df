"""Issue 24, the command line: unreadable values and oversize files are one-line errors, found before the work."""

from __future__ import annotations

from pathlib import Path

import pytest

from server.cli import main

HEAD = "format: footfall/maneuver@1\nname: x\n"


@pytest.mark.parametrize(
    "tail",
    ["duration: 2001-13-45\n", "duration: !!int abc\n", "duration: !!float abc\n", "duration: " + "9" * 5000],
)
def test_unreadable_values_are_one_line_naming_the_line(tmp_path: Path, tail: str, capsys) -> None:
    f = tmp_path / "x.yaml"
    f.write_text(HEAD + tail)
    assert main(["validate", str(f)]) == 2
    out = capsys.readouterr().out.strip()
    assert out.startswith("failure: line 3:") and "Traceback" not in out, out
    assert main(["run", str(f)]) == 2
    err = capsys.readouterr().err.strip()
    assert "line 3" in err and "Traceback" not in err and len(err.splitlines()) == 1, err


def test_a_huge_file_is_refused_before_it_is_read(tmp_path: Path, capsys, monkeypatch) -> None:
    f = tmp_path / "big.yaml"
    with f.open("wb") as out:  # sparse: 50 MB on paper, nothing on disk
        out.truncate(50_000_000)

    read_text, read_bytes = Path.read_text, Path.read_bytes

    def guard(real):  # type: ignore[no-untyped-def]
        def read(self, *a, **k):  # type: ignore[no-untyped-def]
            assert Path(self).resolve() != f.resolve(), "the 50 MB file was read"
            return real(self, *a, **k)

        return read

    monkeypatch.setattr(Path, "read_text", guard(read_text))
    monkeypatch.setattr(Path, "read_bytes", guard(read_bytes))
    assert main(["validate", str(f)]) == 2
    assert "50.0 MB, larger than 1000 kB" in capsys.readouterr().out


def test_too_many_events_are_refused_before_they_are_checked(tmp_path: Path, capsys, monkeypatch) -> None:
    f = tmp_path / "many.yaml"
    events = "".join(f"  - {{t: {i * 0.001:.3f}, leg: FL, type: liftoff}}\n" for i in range(20_000))
    f.write_text(HEAD + "duration: 30\nevents:\n" + events)
    from planning.maneuver import load

    composed: list[int] = []  # counted, not timed: the first 2000 items are composed, not the other 18 000

    class Counting(load._Loader):
        def compose_node(self, parent, index):  # type: ignore[no-untyped-def]
            composed.append(1)
            return super().compose_node(parent, index)

    monkeypatch.setattr(load, "_Loader", Counting)
    assert main(["validate", "--no-solve", str(f)]) == 2
    err = capsys.readouterr().out
    assert f"line {5 + 2000}" in err and "more than 2000 items" in err, err
    assert 2000 < len(composed) < 2001 * 8, len(composed)  # an event is a mapping of three keys and values


def test_bench_runs_on_the_products_own_dependencies(monkeypatch, capsys) -> None:
    """clarabel is a development dependency (the centroidal stage's reference solve): without it the stage runs,
    without the reference error."""
    import sys

    monkeypatch.setitem(sys.modules, "clarabel", None)  # `import clarabel` raises ImportError
    from planning.centroidal.bench import bench_centroidal_tick

    out = bench_centroidal_tick(n_ticks=3)
    assert out["ticks"] == 3 and out["p50_ms"] > 0.0
    assert out["force_error_p50_N"] is None  # no reference without clarabel
