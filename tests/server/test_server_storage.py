"""The library store on its own: names never become paths outside it, writes are atomic, ETags track content."""

from __future__ import annotations

import os
from pathlib import Path

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from server_fakes import files_in

from server.storage import (
    BadName,
    Conflict,
    ManeuverStore,
    NotFound,
    PreconditionRequired,
    ReadOnly,
    atomic_write,
    check_name,
    etag_matches,
    etag_of,
)


@given(st.text(max_size=80))
@settings(max_examples=300, deadline=None)
def test_a_legal_name_is_a_plain_file_name(name: str) -> None:
    try:
        check_name(name)
    except BadName:
        return
    assert "/" not in name and "\\" not in name and not name.startswith(".") and "\x00" not in name
    assert Path(name).name == name and name not in (".", "..")


def test_atomic_write_replaces_whole_or_not_at_all(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    p = tmp_path / "m.yaml"
    atomic_write(p, b"old")

    class Crash(BaseException):  # like a KeyboardInterrupt or the process being killed mid-write
        pass

    def crash(*_a: object) -> None:
        raise Crash

    monkeypatch.setattr(os, "replace", crash)
    with pytest.raises(Crash):
        atomic_write(p, b"new" * 1000)
    monkeypatch.undo()
    assert p.read_bytes() == b"old" and files_in(tmp_path) == ["m.yaml"]

    monkeypatch.setattr(os, "fsync", crash)  # a crash before the data is durable: same outcome
    with pytest.raises(Crash):
        atomic_write(p, b"new")
    monkeypatch.undo()
    assert p.read_bytes() == b"old" and files_in(tmp_path) == ["m.yaml"]
    atomic_write(p, b"new")
    assert p.read_bytes() == b"new"


def test_store_rules(tmp_path: Path) -> None:
    shipped = tmp_path / "shipped"
    shipped.mkdir()
    (shipped / "base.yaml").write_text("format: footfall/maneuver@1\nname: base\nduration: 1.0\n")
    store = ManeuverStore(tmp_path / "user", shipped)
    with pytest.raises(ReadOnly):
        store.save("base", "x")
    stored, created = store.save("mine", "a: 1\n")
    assert created and stored.etag == etag_of(b"a: 1\n")
    with pytest.raises(PreconditionRequired):
        store.save("mine", "a: 2\n")
    with pytest.raises(Conflict):
        store.save("mine", "a: 2\n", if_match='"stale"')
    stored2, created2 = store.save("mine", "a: 2\n", if_match=stored.etag)
    assert not created2 and store.get("mine").text == "a: 2\n"
    with pytest.raises(Conflict):
        store.save("gone", "a: 1\n", if_match=stored.etag)  # If-Match on a file that does not exist
    with pytest.raises(NotFound):
        store.delete("nothing")
    store.delete("mine", if_match=stored2.etag)
    assert files_in(tmp_path / "user") == [".lock"]


def test_etag_matching() -> None:
    e = etag_of(b"x")
    assert etag_matches(e, e) and etag_matches("*", e) and etag_matches(f'"a", W/{e}', e)
    assert not etag_matches('"other"', e)
