"""What the routes and the studio share: settings, the library, sessions, the simulation pool; and the one place
where request bodies become validated maneuvers."""

from __future__ import annotations

import dataclasses
import json
import logging
import time
from dataclasses import dataclass, field
from functools import cached_property
from typing import Any

from planning.maneuver import (
    ManeuverError,
    Problem,
    ValidationResult,
    check_maneuver,
    parse_maneuver,
    validate_maneuver,
)
from planning.maneuver.load import read_yaml
from planning.maneuver.problems import with_lines
from server.errors import ApiError
from server.sessions import SessionManager
from server.settings import Settings
from server.simulations import SimulationPool
from server.storage import ManeuverStore, StorageError, dump_yaml, problems_to_fields

log = logging.getLogger("footfall.api")
YAML_TYPES = ("application/yaml", "application/x-yaml", "text/yaml", "text/x-yaml", "text/plain")


@dataclass
class Services:
    """The service objects of one app; built by create_app, closed by its lifespan."""

    settings: Settings
    store: ManeuverStore
    sessions: SessionManager
    simulations: SimulationPool
    studio: Any = None
    sweeps: Any = None  # server.sweeps.SweepManager, made on first use (server.sweeps.manager_of)
    preview_requests: list[tuple[float, str, str]] = field(
        default_factory=list
    )  # (wall time, maneuver, terrain)

    @cached_property
    def robot(self) -> Any:
        from planning.robot import load_robot

        return load_robot(self.settings.robot)

    def close(self) -> None:
        if self.studio is not None:
            self.studio.stop()
        self.sessions.shutdown()
        self.simulations.shutdown()


@dataclass(frozen=True)
class ManeuverBody:
    """A maneuver sent by a client: the parsed document, the text to store, and whether it came as YAML."""

    data: Any
    text: str
    lines: dict[str, int] | None
    is_yaml: bool


def read_maneuver_body(raw: bytes, content_type: str | None) -> ManeuverBody:
    """Returns the document of a request body (JSON, or YAML by Content-Type); ApiError 4xx when unreadable."""
    ctype = (content_type or "application/json").split(";")[0].strip().lower()
    try:
        text = raw.decode("utf-8")
    except UnicodeDecodeError as e:
        raise ApiError(400, f"body: is not UTF-8 text ({e.reason} at byte {e.start})",
                       [{"field": "body", "reason": "not UTF-8 text"}]) from None  # fmt: skip
    if not text.strip():
        raise ApiError(
            422, "body: is empty; send a maneuver document", [{"field": "body", "reason": "is empty"}]
        )
    if ctype in YAML_TYPES:
        try:
            data, lines = read_yaml(text)
        except ManeuverError as e:
            raise ApiError(422, f"body: {e.problems[0].message}", problems_to_fields(e.problems)) from None
        return ManeuverBody(data, text, lines, True)
    if ctype not in ("application/json", "") and not ctype.endswith("+json"):
        raise ApiError(415, f"Content-Type {ctype!r}: send application/json or application/yaml",
                       [{"field": "Content-Type", "reason": f"unsupported: {ctype[:60]}"}])  # fmt: skip
    try:
        data = json.loads(text, parse_constant=_reject_constant)
    except RecursionError:
        raise ApiError(
            422, "body: nests too deeply", [{"field": "body", "reason": "nests too deeply"}]
        ) from None
    except ValueError as e:
        raise ApiError(422, f"body: is not valid JSON ({e})"[:300],
                       [{"field": "body", "reason": f"not valid JSON: {e}"[:300]}]) from None  # fmt: skip
    return ManeuverBody(data, "", None, False)


def _reject_constant(name: str) -> Any:
    raise ValueError(f"{name} is not a number JSON allows")


def to_maneuver(body_data: Any, lines: dict[str, int] | None, settings: Settings, robot: Any = None) -> Any:
    """Returns the Maneuver of a document; ApiError 422 listing every shape problem (and, with a robot, what the
    rules find in the well-formed rest: every problem in one answer), or a limit exceeded."""
    try:
        maneuver = parse_maneuver(body_data, lines=lines)
    except ManeuverError as e:
        problems = e.problems
        if robot is not None and isinstance(body_data, dict):
            problems = with_lines(validate_maneuver(body_data, robot).failures, lines) or problems
        n = len(problems)
        raise ApiError(422, f"invalid maneuver ({n} problem{'s' if n != 1 else ''}): {problems[0]}"[:500],
                       problems_to_fields(problems)) from None  # fmt: skip
    except RecursionError:
        raise ApiError(
            422, "body: nests too deeply", [{"field": "body", "reason": "nests too deeply"}]
        ) from None
    limit_problems = check_limits(maneuver, settings)
    if limit_problems:
        raise ApiError(422, f"maneuver too large: {limit_problems[0]}", problems_to_fields(limit_problems))
    return maneuver


def check_limits(maneuver: Any, settings: Settings) -> list[Problem]:
    """Returns the server's size limits a maneuver breaks (events after gait expansion, keyframes)."""
    from planning.maneuver import count_events

    out = []
    try:
        n_events = count_events(maneuver)
    except Exception:  # noqa: BLE001 - a gait the counter cannot expand is the validator's to report
        n_events = len(maneuver.events)
    if n_events > settings.max_events:
        out.append(Problem("events", f"has {n_events} events after gait expansion; the server takes at most "
                                     f"{settings.max_events}"))  # fmt: skip
    if len(maneuver.body) > settings.max_keyframes:
        out.append(Problem("body", f"has {len(maneuver.body)} keyframes; at most {settings.max_keyframes}"))
    return out


def robot_model(services: Services, robot: str | None = None) -> Any:
    """Gives the RobotModel of `robot` (what a simulation loads: a shipped name or a path, as resolve_robot gives
    it), or of the server's robot when None."""
    if robot is None:
        return services.robot
    from server.engine import _robot

    return _robot(robot)


def validate(
    maneuver: Any, services: Services, lines: dict[str, int] | None = None, robot: str | None = None
) -> Any:
    """Returns the ValidationResult of a parsed maneuver for `robot` (resolved: see robot_model; None: the server's
    robot), problems with YAML lines: the same check as `footfall validate`, dry solve included."""
    try:
        result = check_maneuver(maneuver, robot_model(services, robot))
    except Exception as e:  # noqa: BLE001 - a checker that chokes on odd input must not turn into a 500
        log.warning("validation of %s raised %r", getattr(maneuver, "name", "?"), e)
        failure = Problem(
            "", f"the maneuver could not be checked ({type(e).__name__}: {e}); is a value extreme?"
        )
        return ValidationResult(False, [], [failure], maneuver)
    if lines:
        result = dataclasses.replace(
            result, warnings=with_lines(result.warnings, lines), failures=with_lines(result.failures, lines)
        )
    return result


class PhysicsUnavailable(Exception):
    """The physics check could not run (too long, timed out, the worker failed); the message says why."""


def physics_report(maneuver: Any, services: Services, robot: str | None = None) -> dict[str, Any]:
    """Runs the physics check of a maneuver on the simulation pool (it waits its turn with the queued simulations)
    and returns its run report; QueueFull when the queue is full, PhysicsUnavailable when it cannot run. Blocks:
    call it off the event loop."""
    settings = services.settings
    if maneuver.duration > settings.max_sim_duration_s:
        raise PhysicsUnavailable(f"the maneuver lasts {maneuver.duration:g} s; the server simulates at most "
                                 f"{settings.max_sim_duration_s:g} s")  # fmt: skip
    payload = {
        "maneuver": maneuver.model_dump(by_alias=True, mode="json"),
        "terrain": "flat",
        "pushes": [],
        "duration": None,
        "robot": robot or settings.robot,
        "physics_check": True,
    }
    pool = services.simulations
    if pool.closed:
        raise PhysicsUnavailable("the server is shutting down")
    job = pool.submit({"maneuver": maneuver.name, "physics_check": True, "terrain": "flat"}, payload)
    deadline = time.monotonic() + settings.physics_timeout_s
    while True:
        got = pool.get(job.id)
        if got is None or got[0].status in ("done", "failed", "cancelled"):
            break
        if pool.closed:
            raise PhysicsUnavailable("the server is shutting down")
        if time.monotonic() > deadline:
            pool.cancel(job.id)
            raise PhysicsUnavailable(f"it did not finish within {settings.physics_timeout_s:g} s (the simulation "
                                     "queue is busy); validate again later")  # fmt: skip
        time.sleep(0.05)
    done = got[0] if got is not None else job
    if done.status != "done" or not isinstance(done.report, dict):
        log.warning("physics check of %s: %s", maneuver.name, done.error)
        raise PhysicsUnavailable(f"the run did not finish: {done.error or done.status}")
    return done.report


def validate_with_physics(
    maneuver: Any,
    services: Services,
    lines: dict[str, int] | None = None,
    physics: bool | None = None,
    robot: str | None = None,
) -> Any:
    """Returns `validate` plus, when the rules and the dry solve pass, the physics check (physics_report) judged
    into it. physics None: the server's setting (on unless FOOTFALL_VALIDATE_PHYSICS=0). Blocks: call it off the
    event loop."""
    from planning.maneuver.physics import skipped, with_physics

    result = validate(maneuver, services, lines, robot)
    if not (services.settings.validate_physics if physics is None else physics):
        return result
    if not result.ok:
        return skipped(result, "the maneuver has failures without simulating it")
    try:
        return with_physics(result, physics_report(maneuver, services, robot), lines)
    except PhysicsUnavailable as e:
        return skipped(result, f"the physics check could not run: {e}")
    except (KeyError, TypeError, ValueError) as e:  # an odd report must not turn into a 500
        log.warning("physics check of %s: judging its report raised %r", maneuver.name, e)
        return skipped(result, f"the physics check's report could not be read ({type(e).__name__})")


def require_valid(
    maneuver: Any, services: Services, lines: dict[str, int] | None = None, physics: bool | None = False
) -> Any:
    """Returns the validation result when it has no failures; ApiError 422 with the failures otherwise.
    physics: also run the physics check (validate_with_physics); off by default (a simulation validates what it
    runs without running it twice)."""
    result = (
        validate_with_physics(maneuver, services, lines, physics)
        if physics is not False
        else validate(maneuver, services, lines)
    )
    if not result.ok:
        n = len(result.failures)
        first = result.failures[0] if result.failures else "invalid"
        raise ApiError(422, f"maneuver {maneuver.name} has {n} failure{'s' if n != 1 else ''}: {first}"[:500],
                       problems_to_fields(result.failures))  # fmt: skip
    return result


def resolve_maneuver(ref: str | dict[str, Any], services: Services, field_name: str = "maneuver") -> Any:
    """Returns a validated Maneuver from a library name or an inline document; ApiError 404/422 otherwise."""
    if isinstance(ref, str):
        try:
            stored = services.store.get(ref)
        except StorageError as e:
            reason = e.message.removeprefix("name: ")
            # the request's own resource exists: a body naming a maneuver that does not is unprocessable (422)
            raise ApiError(
                422 if e.status == 404 else e.status,
                f"{field_name}: {reason}",
                [{"field": field_name, "reason": reason}],
            ) from None
        try:
            data, lines = read_yaml(stored.text)
        except ManeuverError as e:
            reason = f"the library file of {ref!r} does not load: {e.problems[0].message}"
            raise ApiError(422, f"{field_name}: {reason}"[:500], problems_to_fields(e.problems)) from None
        maneuver = to_maneuver(data, lines, services.settings, services.robot)
    else:
        maneuver = to_maneuver(ref, None, services.settings, services.robot)
    require_valid(maneuver, services)
    return maneuver


def maneuver_text(body: ManeuverBody, maneuver: Any) -> str:
    """Returns the text to store: YAML as sent (comments kept), or JSON converted to block YAML."""
    if body.is_yaml:
        return body.text if body.text.endswith("\n") else body.text + "\n"
    return dump_yaml(body.data)
