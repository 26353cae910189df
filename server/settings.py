"""One settings object for the service and the studio, read from the environment (and the command line).

Environment variables (all optional):

| variable | default | meaning |
| --- | --- | --- |
| ``FOOTFALL_HOST`` | ``127.0.0.1`` | address the REST API binds to |
| ``FOOTFALL_PORT`` | ``8000`` | REST API port |
| ``FOOTFALL_VIEWER_PORT`` | ``8080`` | studio (viser) port |
| ``FOOTFALL_DATA_DIR`` | ``$XDG_DATA_HOME/footfall`` or ``~/.local/share/footfall`` | user maneuvers live in ``<dir>/maneuvers`` |
| ``FOOTFALL_API_TOKEN`` | unset | token required in ``X-Footfall-Token`` (or ``Authorization: Bearer``) for writes |
| ``FOOTFALL_ALLOW_OPEN`` | ``0`` | ``1``: accept writes without a token even when bound beyond loopback |
| ``FOOTFALL_MAX_SESSIONS`` | ``4`` | live simulated robots at once (each needs a share of a core) |
| ``FOOTFALL_SESSION_IDLE_S`` | ``600`` | a session nobody touched for this long is ended, s |
| ``FOOTFALL_SESSION_WORKERS`` | ``auto`` | ``process``: each live session in a worker process; ``thread``: all in the server's process; ``auto``: processes for the real simulation |
| ``FOOTFALL_SIM_WORKERS`` | ``1`` | worker processes for queued headless simulations |
| ``FOOTFALL_MAX_QUEUED`` | ``16`` | simulations waiting at once; more are refused with 429 |
| ``FOOTFALL_MAX_BODY_BYTES`` | ``262144`` | largest request body, bytes |
| ``FOOTFALL_ROBOT`` | ``spot`` | robot description the sessions and validation use |
| ``FOOTFALL_STUDIO`` | ``1`` | ``0``: REST API only, no viser studio |
| ``FOOTFALL_BACKEND`` | ``local`` | ``ray``: queued simulations and sweeps run as Ray tasks (``footfall serve --backend``) |
| ``FOOTFALL_RAY_ADDRESS`` | unset | the Ray cluster to use (unset: a local Ray started by the server) |
| ``FOOTFALL_VALIDATE_PHYSICS`` | ``1`` | ``0``: validation skips its physics check unless a request asks (``?physics=true``) |
| ``FOOTFALL_PHYSICS_TIMEOUT_S`` | ``300`` | longest a validation waits for its physics check (queue included), s |
"""

from __future__ import annotations

import dataclasses
import ipaddress
import math
import os
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

LOOPBACK_NAMES = frozenset({"localhost", "ip6-localhost"})


class SettingsError(ValueError):
    """A setting from the environment or the command line that cannot be used; the message names it."""


def default_data_dir(env: Mapping[str, str] | None = None) -> Path:
    """Returns where user data lives: $XDG_DATA_HOME/footfall, else ~/.local/share/footfall."""
    env = os.environ if env is None else env
    xdg = env.get("XDG_DATA_HOME")
    base = Path(xdg) if xdg else Path.home() / ".local" / "share"
    return base / "footfall"


def display_host(host: str) -> str:
    """Returns the host to show in a URL for a bind address: the address itself (IPv6 in brackets); for a
    wildcard bind, the loopback address it also answers on."""
    if host in ("0.0.0.0", ""):
        return "127.0.0.1"
    if host == "::":
        return "[::1]"
    return f"[{host}]" if ":" in host else host


def is_loopback(host: str) -> bool:
    """Returns True when `host` only accepts connections from this machine."""
    if host in LOOPBACK_NAMES:
        return True
    try:
        return ipaddress.ip_address(host).is_loopback
    except ValueError:
        return False


@dataclass(frozen=True)
class Settings:
    """Everything the service and the studio can be told; defaults are safe for a laptop."""

    host: str = "127.0.0.1"
    port: int = 8000
    viewer_port: int = 8080
    data_dir: Path = field(default_factory=default_data_dir)
    library_dir: Path | None = None  # None: the repository's shipped maneuvers/ directory
    api_token: str | None = None
    allow_open: bool = False
    robot: str = "spot"
    studio: bool = True
    studio_shadows: bool = True  # a new studio tab draws shadows (each tab can switch them in View)
    # limits
    max_body_bytes: int = 256 * 1024
    max_events: int = 2000  # explicit events plus events expanded from gaits
    max_keyframes: int = 500
    max_pushes: int = 50
    max_sessions: int = 4
    session_idle_s: float = 600.0
    reaper_period_s: float = 5.0
    session_workers: str = "auto"  # "process", "thread", "auto" (processes unless a test injects a fake)
    sim_workers: int = 1
    max_queued_simulations: int = 16
    max_kept_simulations: int = 200  # finished simulations remembered for GET /simulations/{id}
    max_sim_duration_s: float = 120.0
    backend: str = "local"  # where queued simulations and sweeps run: local worker processes, or "ray"
    ray_address: str | None = None  # backend ray: the cluster (None: a local Ray started on first use)
    validate_physics: bool = True  # validation runs the physics check unless the request says physics=false
    physics_timeout_s: float = (
        300.0  # a validation waits at most this long for its physics check (queue included)
    )

    @property
    def user_dir(self) -> Path:
        """Returns the directory of the user's maneuvers (created on first write)."""
        return self.data_dir / "maneuvers"

    @property
    def token_required(self) -> bool:
        """True when writes and driving need the API token: bound beyond loopback and not explicitly open."""
        if self.api_token:
            return True
        return not is_loopback(self.host) and not self.allow_open

    def check(self) -> Settings:
        """Returns self when every value is usable; raises SettingsError naming the first bad one."""
        for name in ("port", "viewer_port"):
            v = getattr(self, name)
            if not 0 <= v <= 65535:
                raise SettingsError(f"{name}: {v} is not a TCP port (0..65535)")
        positive = (
            "max_body_bytes", "max_events", "max_keyframes", "max_sessions", "session_idle_s", "sim_workers",
            "max_queued_simulations", "max_sim_duration_s", "reaper_period_s", "physics_timeout_s",
        )  # fmt: skip
        for name in positive:
            if not math.isfinite(getattr(self, name)):
                raise SettingsError(f"{name}: must be a finite number, got {getattr(self, name)}")
            if getattr(self, name) <= 0:
                raise SettingsError(f"{name}: must be positive, got {getattr(self, name)}")
        if self.session_workers not in ("auto", "process", "thread"):
            raise SettingsError(f"session_workers: {self.session_workers!r} is not auto, process or thread")
        if self.backend not in ("local", "ray"):
            raise SettingsError(f"backend: {self.backend!r} is not local or ray")
        if self.api_token is not None and len(self.api_token) < 8:
            raise SettingsError("FOOTFALL_API_TOKEN: must be at least 8 characters")
        return self

    def replace(self, **changes: Any) -> Settings:
        """Returns a copy with some fields changed (None values are ignored, so CLI defaults do not override)."""
        return dataclasses.replace(self, **{k: v for k, v in changes.items() if v is not None})

    @classmethod
    def from_env(cls, env: Mapping[str, str] | None = None, **overrides: Any) -> Settings:
        """Returns settings from FOOTFALL_* variables, then `overrides` (e.g. from the command line) on top."""
        env = os.environ if env is None else env
        values: dict[str, Any] = {"data_dir": default_data_dir(env)}

        def read(var: str, key: str, conv: Any) -> None:
            raw = env.get(var)
            if raw is None or raw == "":
                return
            try:
                values[key] = conv(raw)
            except ValueError:
                raise SettingsError(f"{var}={raw!r}: expected {conv.__name__}") from None

        def flag(raw: str) -> bool:
            low = raw.strip().lower()
            if low in ("1", "true", "yes", "on"):
                return True
            if low in ("0", "false", "no", "off"):
                return False
            raise ValueError(raw)

        flag.__name__ = "a flag (1/0)"
        read("FOOTFALL_HOST", "host", str)
        read("FOOTFALL_PORT", "port", int)
        read("FOOTFALL_VIEWER_PORT", "viewer_port", int)
        read("FOOTFALL_DATA_DIR", "data_dir", lambda s: Path(s).expanduser())
        read("FOOTFALL_LIBRARY_DIR", "library_dir", lambda s: Path(s).expanduser())
        read("FOOTFALL_API_TOKEN", "api_token", str)
        read("FOOTFALL_ALLOW_OPEN", "allow_open", flag)
        read("FOOTFALL_ROBOT", "robot", str)
        read("FOOTFALL_STUDIO", "studio", flag)
        read("FOOTFALL_STUDIO_SHADOWS", "studio_shadows", flag)
        read("FOOTFALL_MAX_SESSIONS", "max_sessions", int)
        read("FOOTFALL_SESSION_IDLE_S", "session_idle_s", float)
        read("FOOTFALL_SESSION_WORKERS", "session_workers", str)
        read("FOOTFALL_SIM_WORKERS", "sim_workers", int)
        read("FOOTFALL_MAX_QUEUED", "max_queued_simulations", int)
        read("FOOTFALL_MAX_BODY_BYTES", "max_body_bytes", int)
        read("FOOTFALL_BACKEND", "backend", str)
        read("FOOTFALL_RAY_ADDRESS", "ray_address", str)
        read("FOOTFALL_VALIDATE_PHYSICS", "validate_physics", flag)
        read("FOOTFALL_PHYSICS_TIMEOUT_S", "physics_timeout_s", float)
        values.update({k: v for k, v in overrides.items() if v is not None})
        return cls(**values).check()
