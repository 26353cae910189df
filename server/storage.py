"""The maneuver library: the shipped directory (read-only) and the user's directory (atomic writes, ETags).

Names are checked against the format's name pattern before they become paths, so no request can reach outside the
two directories. A write goes to a temporary file in the target directory, is flushed and fsynced, then renamed over
the old file (and the directory fsynced): a crash leaves either the old file or the new one, never half of one.
Concurrent edits are detected with ETags (a hash of the file's bytes): a replace must name the ETag it started from.
"""

from __future__ import annotations

import contextlib
import fcntl
import hashlib
import os
import re
import tempfile
import threading
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Literal

import yaml

from planning.maneuver import SHIPPED_LIBRARY, ManeuverError, Problem, list_library
from planning.maneuver.spec import NAME_PATTERN

Source = Literal["shipped", "user"]
MAX_NAME_LEN = 64
_NAME_RE = re.compile(NAME_PATTERN)


class StorageError(Exception):
    """A library operation that cannot be done; `status` is the HTTP status the API answers with."""

    status = 400

    def __init__(self, message: str, field: str = "name") -> None:
        super().__init__(message)
        self.message = message
        self.field = field


class NotFound(StorageError):
    status = 404


class ReadOnly(StorageError):
    status = 403


class Conflict(StorageError):
    status = 409


class PreconditionRequired(StorageError):
    status = 428


class BadName(StorageError, ValueError):
    """Also a ValueError, so pydantic validators can raise it."""

    status = 422


def check_name(name: str) -> str:
    """Returns the name when it is a legal maneuver name; raises BadName saying why otherwise."""
    if not isinstance(name, str) or not name:
        raise BadName("name: is required")
    if len(name) > MAX_NAME_LEN:
        raise BadName(f"name: is too long (at most {MAX_NAME_LEN} characters)")
    if not _NAME_RE.fullmatch(name):
        raise BadName(
            f"name: {name[:80]!r} is not a maneuver name (lowercase letters, digits and single dashes)"
        )
    return name


def etag_of(data: bytes) -> str:
    """Returns the strong ETag (quoted) of a file's bytes."""
    return '"' + hashlib.sha256(data).hexdigest()[:32] + '"'


def etag_matches(header: str, etag: str) -> bool:
    """Returns True when an If-Match header value names `etag` (or is `*`); weak prefixes are ignored."""
    for part in header.split(","):
        tag = part.strip().removeprefix("W/")
        if tag == "*" or tag == etag:
            return True
    return False


@dataclass(frozen=True)
class StoredManeuver:
    """A maneuver file as stored: its bytes, its parsed document, where it lives, its ETag."""

    name: str
    source: Source
    path: Path
    text: str
    etag: str

    @property
    def editable(self) -> bool:
        return self.source == "user"


def dump_yaml(document: dict[str, Any]) -> str:
    """Returns a maneuver document as block-style YAML (keys in the given order)."""
    return yaml.safe_dump(document, sort_keys=False, allow_unicode=True, default_flow_style=None, width=110)


def _fsync_dir(directory: Path) -> None:
    try:
        fd = os.open(directory, os.O_RDONLY)
    except OSError:
        return
    try:
        os.fsync(fd)
    except OSError:  # some filesystems refuse to fsync a directory; the rename is still atomic
        pass
    finally:
        os.close(fd)


def atomic_write(path: Path, data: bytes) -> None:
    """Writes `data` to `path` so a crash leaves the old file or the new one: temp file, fsync, rename, fsync dir."""
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=f".{path.name}.", suffix=".tmp")
    try:
        os.fchmod(fd, 0o644)  # mkstemp makes 0600; a library file is as readable as any other document
        with os.fdopen(fd, "wb") as f:
            f.write(data)
            f.flush()
            os.fsync(f.fileno())
        os.replace(tmp, path)
    except BaseException:
        with contextlib.suppress(OSError):
            os.unlink(tmp)
        raise
    _fsync_dir(path.parent)


class ManeuverStore:
    """The shipped library (read-only) and the user's library (writable), shipped names first.

    Thread-safe within a process (one lock) and across processes sharing the data directory (an flock on
    ``.lock`` around each check-then-write).
    """

    def __init__(self, user_dir: Path, shipped_dir: Path | None = None) -> None:
        self.shipped_dir = Path(shipped_dir) if shipped_dir is not None else SHIPPED_LIBRARY
        self.user_dir = Path(user_dir)
        self._lock = threading.Lock()

    # ---- reading ------------------------------------------------------------------------------------------------
    def _file(self, directory: Path, name: str) -> Path | None:
        for ext in (".yaml", ".yml"):
            p = directory / f"{name}{ext}"
            if p.is_file():
                return p
        return None

    def locate(self, name: str) -> tuple[Source, Path] | None:
        """Returns (source, path) of a maneuver by name, shipped first, or None."""
        check_name(name)
        p = self._file(self.shipped_dir, name)
        if p is not None:
            return "shipped", p
        p = self._file(self.user_dir, name)
        if p is not None:
            return "user", p
        return None

    def get(self, name: str) -> StoredManeuver:
        """Returns a stored maneuver; raises NotFound (or BadName)."""
        found = self.locate(name)
        if found is None:
            raise NotFound(f"no maneuver named {name!r}")
        source, path = found
        try:
            data = path.read_bytes()
        except OSError as e:
            raise NotFound(f"maneuver {name!r} cannot be read: {e.strerror}") from None
        return StoredManeuver(name, source, path, data.decode("utf-8", "replace"), etag_of(data))

    def list(self) -> list[dict[str, Any]]:
        """Returns one entry per maneuver: name, title, duration, source, editable, and load problems if any."""
        out = []
        for e in list_library([self.shipped_dir, self.user_dir]):
            source: Source = "shipped" if e.path.parent.resolve() == self.shipped_dir.resolve() else "user"
            entry: dict[str, Any] = {
                "name": e.name if _NAME_RE.fullmatch(e.name) else e.path.stem,
                "title": e.title,
                "duration": e.duration_s,
                "source": source,
                "editable": source == "user",
            }
            if e.problems:
                entry["problems"] = [p.to_dict() for p in e.problems]
            out.append(entry)
        return out

    def clean_temp_files(self) -> tuple[Path, ...]:
        """Removes the temporary files of writes that were killed midway (`.<name>.*.tmp`); returns them.

        Called at start. Under the lock, so a write of another server sharing the directory is never cut short.
        """
        if not self.user_dir.is_dir():
            return ()
        removed: tuple[Path, ...] = ()
        with self._locked():
            for p in self.user_dir.glob(".*.tmp"):
                with contextlib.suppress(OSError):
                    p.unlink()
                    removed += (p,)
        return removed

    # ---- writing ------------------------------------------------------------------------------------------------
    @contextlib.contextmanager
    def _locked(self) -> Iterator[None]:
        self.user_dir.mkdir(parents=True, exist_ok=True)
        with self._lock, open(self.user_dir / ".lock", "a+b") as lock_file:
            fcntl.flock(lock_file.fileno(), fcntl.LOCK_EX)
            try:
                yield
            finally:
                fcntl.flock(lock_file.fileno(), fcntl.LOCK_UN)

    def _check_writable(self, name: str) -> None:
        check_name(name)
        if self._file(self.shipped_dir, name) is not None:
            raise ReadOnly(f"{name!r} is a shipped maneuver and read-only; save it under another name")

    def _check_precondition(
        self, name: str, current: Path | None, if_match: str | None, if_none_match: str | None
    ) -> None:
        if if_none_match is not None and if_none_match.strip() == "*" and current is not None:
            raise Conflict(f"maneuver {name!r} already exists (If-None-Match: *)", field="If-None-Match")
        if current is None:
            if if_match is not None and if_match.strip() != "*":
                raise Conflict(
                    f"maneuver {name!r} does not exist any more (deleted since you read it)", field="If-Match"
                )
            return
        if if_match is None:
            raise PreconditionRequired(
                f"replacing {name!r} needs an If-Match header with the ETag you read (GET /maneuvers/{name}), "
                "or If-Match: * to overwrite",
                field="If-Match",
            )
        etag = etag_of(current.read_bytes())
        if not etag_matches(if_match, etag):
            raise Conflict(
                f"maneuver {name!r} was changed by someone else since you read it (ETag {etag}); "
                "reload it and apply your edit again",
                field="If-Match",
            )

    def save(
        self, name: str, text: str, *, if_match: str | None = None, if_none_match: str | None = None
    ) -> tuple[StoredManeuver, bool]:
        """Writes a user maneuver atomically; returns (stored, created). The caller has validated `text`."""
        self._check_writable(name)
        data = text.encode("utf-8")
        with self._locked():
            current = self._file(self.user_dir, name)
            self._check_precondition(name, current, if_match, if_none_match)
            path = current if current is not None else self.user_dir / f"{name}.yaml"
            atomic_write(path, data)
        return StoredManeuver(name, "user", path, text, etag_of(data)), current is None

    def delete(self, name: str, *, if_match: str | None = None) -> None:
        """Removes a user maneuver; raises NotFound, ReadOnly (shipped) or Conflict (stale If-Match)."""
        self._check_writable(name)
        with self._locked():
            current = self._file(self.user_dir, name)
            if current is None:
                raise NotFound(f"no user maneuver named {name!r}")
            if if_match is not None:
                etag = etag_of(current.read_bytes())
                if not etag_matches(if_match, etag):
                    raise Conflict(
                        f"maneuver {name!r} was changed since you read it (ETag {etag})", field="If-Match"
                    )
            current.unlink()
            _fsync_dir(self.user_dir)


def problems_to_fields(problems: list[Problem]) -> list[dict[str, Any]]:
    """Returns problems as the API's error entries: field, reason, plus the maneuver problem's own keys."""
    return [{"field": p.path, "reason": p.message, **p.to_dict()} for p in problems]


__all__ = [
    "BadName",
    "Conflict",
    "ManeuverError",
    "ManeuverStore",
    "NotFound",
    "PreconditionRequired",
    "ReadOnly",
    "StorageError",
    "StoredManeuver",
    "atomic_write",
    "check_name",
    "dump_yaml",
    "etag_of",
    "etag_matches",
    "problems_to_fields",
]
