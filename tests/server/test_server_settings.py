"""Settings from the environment: defaults, overrides, and a clear error naming a bad variable."""

from __future__ import annotations

from pathlib import Path

import pytest

from server.settings import Settings, SettingsError, default_data_dir


def test_defaults_are_safe() -> None:
    s = Settings.from_env({"HOME": "/home/u"})
    assert s.host == "127.0.0.1" and s.port == 8000 and s.viewer_port == 8080
    assert not s.token_required and s.api_token is None


def test_data_dir_from_env_and_xdg(tmp_path: Path) -> None:
    assert Settings.from_env({"FOOTFALL_DATA_DIR": str(tmp_path)}).user_dir == tmp_path / "maneuvers"
    assert default_data_dir({"XDG_DATA_HOME": "/x"}) == Path("/x/footfall")
    assert default_data_dir({}).parts[-3:] == (".local", "share", "footfall")


def test_env_and_overrides() -> None:
    env = {"FOOTFALL_HOST": "0.0.0.0", "FOOTFALL_PORT": "9000", "FOOTFALL_API_TOKEN": "abcdefgh12",
           "FOOTFALL_MAX_SESSIONS": "2", "FOOTFALL_ALLOW_OPEN": "yes"}  # fmt: skip
    s = Settings.from_env(env, port=9001, viewer_port=None)
    assert s.host == "0.0.0.0" and s.port == 9001 and s.viewer_port == 8080 and s.max_sessions == 2
    assert s.allow_open and s.token_required  # a token, once set, is always required


@pytest.mark.parametrize(
    "env,needle",
    [
        ({"FOOTFALL_PORT": "eighty"}, "FOOTFALL_PORT"),
        ({"FOOTFALL_PORT": "70000"}, "port"),
        ({"FOOTFALL_ALLOW_OPEN": "maybe"}, "FOOTFALL_ALLOW_OPEN"),
        ({"FOOTFALL_MAX_SESSIONS": "0"}, "max_sessions"),
        ({"FOOTFALL_API_TOKEN": "short"}, "FOOTFALL_API_TOKEN"),
    ],
)
def test_bad_values_name_the_variable(env: dict[str, str], needle: str) -> None:
    with pytest.raises(SettingsError, match=needle):
        Settings.from_env(env)
