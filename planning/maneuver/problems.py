"""Problems found in a maneuver: a field path, a plain reason, a severity; and the error that carries them."""

from __future__ import annotations

from collections.abc import Iterable, Sequence
from dataclasses import dataclass, replace
from typing import Literal

Severity = Literal["failure", "warning"]


@dataclass(frozen=True)
class Problem:
    """One thing wrong with a maneuver. `path` is a field path like ``events[3].t`` ("" for the whole file)."""

    path: str
    message: str
    severity: Severity = "failure"
    line: int | None = None  # 1-based line in the YAML source, when the maneuver came from text

    def __str__(self) -> str:
        return f"{self.path}: {self.message}" if self.path else self.message

    def located(self) -> str:
        """Returns the problem as one line with its YAML line number in front when known."""
        return f"line {self.line}: {self}" if self.line is not None else str(self)

    def to_dict(self) -> dict[str, object]:
        """Returns a JSON-ready dict (the REST answer's shape)."""
        return {"path": self.path, "message": self.message, "severity": self.severity, "line": self.line}


class ManeuverError(ValueError):
    """A maneuver that cannot be used; carries every problem found, never a traceback's worth of internals."""

    def __init__(self, problems: Sequence[Problem], source: str | None = None) -> None:
        self.problems: list[Problem] = list(problems)
        self.source = source
        head = f"{source}: " if source else ""
        n = len(self.problems)
        lines = "\n".join(f"  {p.located()}" for p in self.problems)
        super().__init__(f"{head}invalid maneuver ({n} problem{'s' if n != 1 else ''}):\n{lines}")

    @property
    def failures(self) -> list[Problem]:
        return [p for p in self.problems if p.severity == "failure"]


def with_lines(problems: Iterable[Problem], lines: dict[str, int] | None) -> list[Problem]:
    """Returns the problems with `line` filled from a path → line map (the longest known prefix of each path)."""
    if not lines:
        return list(problems)
    out = []
    for p in problems:
        path = p.path
        while path and path not in lines:
            cut = max(path.rfind("."), path.rfind("["))
            path = path[:cut] if cut > 0 else ""
        out.append(replace(p, line=lines.get(path, p.line)))
    return out
