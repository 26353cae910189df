"""The footfall service: `create_app(settings)` builds the FastAPI app; `serve()` runs it with the viser studio."""

from __future__ import annotations

import logging
import secrets
import sys
from collections.abc import AsyncIterator
from contextlib import asynccontextmanager
from typing import Any

from fastapi import FastAPI
from fastapi.openapi.utils import get_openapi
from fastapi.staticfiles import StaticFiles

from server import docs, errors
from server.api import api_router
from server.api.studio import WEB_DIR
from server.services import Services
from server.sessions import SessionManager, SimFactory
from server.settings import Settings, SettingsError, display_host, is_loopback
from server.simulations import Runner, SimulationPool
from server.storage import ManeuverStore

log = logging.getLogger("footfall")
VERSION = "0.1.0"
DESCRIPTION = """\
Author legged-robot maneuvers and run them on a MuJoCo simulation of a Spot-class quadruped.

* **Maneuvers**: the library (shipped, read-only; and yours), validated on write, with ETags for concurrent edits.
* **Simulations**: queued headless runs answering with the run report.
* **Sessions**: live simulated robots stepping in real time (the studio drives one per browser tab).

Errors are `{"detail": "...", "errors": [{"field": ..., "reason": ...}]}`. When the server is bound beyond
loopback, requests that write or drive need the `X-Footfall-Token` header.
"""


def build_services(
    settings: Settings, sim_factory: SimFactory | None = None, sim_runner: Runner | None = None
) -> Services:
    """Returns the service objects for the settings (nothing started yet)."""
    return Services(
        settings=settings,
        store=ManeuverStore(settings.user_dir, settings.library_dir),
        sessions=SessionManager(settings, sim_factory),
        simulations=SimulationPool(settings, sim_runner),
    )


def _openapi(app: FastAPI) -> dict[str, Any]:
    """Returns the OpenAPI schema with the maneuver file's schema as components (bodies read raw reference it)."""
    if app.openapi_schema:
        return app.openapi_schema
    from planning.maneuver.spec import Maneuver

    schema = get_openapi(title=app.title, version=app.version, description=app.description, routes=app.routes)
    m = Maneuver.model_json_schema(
        by_alias=True, mode="validation", ref_template="#/components/schemas/{model}"
    )
    comps = schema.setdefault("components", {}).setdefault("schemas", {})
    for k, v in m.pop("$defs", {}).items():
        comps.setdefault(k, v)
    comps["Maneuver"] = m
    from server.api.openapi import describe_errors

    app.openapi_schema = describe_errors(schema)
    return schema


def create_app(
    settings: Settings | None = None,
    *,
    sim_factory: SimFactory | None = None,
    sim_runner: Runner | None = None,
    with_studio: bool = False,
    check_host: bool = False,
) -> FastAPI:
    """Returns the REST app; the studio (viser) starts with it when `with_studio` and the settings allow.

    check_host (what `serve` does): bound to loopback, answer only requests addressed to a loopback name (421
    otherwise), against DNS rebinding; in-process test clients address `testserver` and leave it off.
    """
    settings = settings or Settings.from_env()
    services = build_services(settings, sim_factory, sim_runner)

    @asynccontextmanager
    async def lifespan(app: FastAPI) -> AsyncIterator[None]:
        for p in services.store.clean_temp_files():
            log.info("removed %s, left by a write that was killed midway", p.name)
        services.sessions.start()
        if with_studio and settings.studio:
            from server.studio import Studio

            services.studio = Studio(services)
            services.studio.start()
        try:
            yield
        finally:
            services.close()
            if services.sweeps is not None:
                services.sweeps.shutdown()

    app = FastAPI(
        title="footfall",
        version=VERSION,
        description=DESCRIPTION,
        lifespan=lifespan,
        docs_url=None,  # served from the package by server.docs (FastAPI's own pages load a CDN)
        redoc_url=None,
    )
    app.state.services = services
    errors.install(app)
    app.add_middleware(errors.BodyLimit, max_bytes=settings.max_body_bytes)
    if check_host and is_loopback(settings.host):
        allowed = {"localhost", "127.0.0.1", "::1", errors.HostCheck.host_name(settings.host)}
        app.add_middleware(errors.HostCheck, allowed=frozenset(allowed))
    app.include_router(api_router)
    docs.install(app)
    if WEB_DIR.is_dir():
        app.mount("/static", StaticFiles(directory=WEB_DIR), name="static")
    app.openapi = lambda: _openapi(app)  # type: ignore[method-assign]
    return app


def serve(
    host: str | None = None, port: int | None = None, viewer_port: int | None = None, **overrides: Any
) -> None:
    """Runs the REST API (uvicorn) and the studio until interrupted.

    Arguments (and `overrides`: any Settings field, e.g. data_dir=Path(...)) win over FOOTFALL_* variables; None
    means "not given".
    """
    import uvicorn

    logging.basicConfig(level=logging.INFO, format="%(asctime)s %(name)s %(levelname)s %(message)s")
    try:
        settings = Settings.from_env(host=host, port=port, viewer_port=viewer_port, **overrides)
    except SettingsError as e:
        print(f"footfall: error: {e}", file=sys.stderr)
        raise SystemExit(2) from None
    if settings.token_required and not settings.api_token:
        # Bound beyond loopback without a token: make one up rather than serve writes to the network.
        settings = settings.replace(api_token=secrets.token_urlsafe(18))
        print(
            f"footfall: bound to {settings.host} without FOOTFALL_API_TOKEN; requests that write or drive need\n"
            f"          the header  X-Footfall-Token: {settings.api_token}\n"
            "          (set FOOTFALL_API_TOKEN to choose it, or FOOTFALL_ALLOW_OPEN=1 on a trusted network)",
            file=sys.stderr,
            flush=True,
        )
    app = create_app(settings, with_studio=True, check_host=True)
    shown = display_host(settings.host)
    print(
        f"footfall: REST API on http://{shown}:{settings.port} (docs at /docs), "
        f"studio on http://{shown}:{settings.viewer_port}, user maneuvers in {settings.user_dir}",
        file=sys.stderr,
        flush=True,
    )
    uvicorn.run(app, host=settings.host, port=settings.port, log_level="info", server_header=False)
