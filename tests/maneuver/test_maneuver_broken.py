"""Each file in broken/ says in its first line which failure it must produce, with the field path."""

from __future__ import annotations

from pathlib import Path

import pytest

from planning.maneuver import validate_maneuver

BROKEN = sorted((Path(__file__).parent / "broken").glob("*.yaml"))


def _expectation(path: Path) -> tuple[str, str]:
    first = path.read_text().splitlines()[0]
    assert first.startswith("# expect: "), f"{path.name} must start with '# expect: PATH: TEXT'"
    field, text = first.removeprefix("# expect: ").split(": ", 1)
    return ("" if field == "(file)" else field), text


def test_there_are_broken_files() -> None:
    assert len(BROKEN) >= 20


@pytest.mark.parametrize("path", BROKEN, ids=lambda p: p.stem)
def test_broken_file_fails_with_its_path_and_reason(path, robot) -> None:
    field, text = _expectation(path)
    result = validate_maneuver(path, robot)
    assert not result.ok
    shown = [f"{p.path!r}: {p.message}" for p in result.failures]
    assert any(p.path == field and text in p.message for p in result.failures), shown
    assert all(p.line is not None for p in result.failures), "problems of a file carry their line"
    assert not any(
        "Traceback" in p.message or "could not run the check" in p.message for p in result.failures
    )
