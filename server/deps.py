"""Dependencies of the routes, as named `Annotated` aliases (async: trivial, so no trip through the threadpool)."""

from __future__ import annotations

import secrets
from typing import Annotated

from fastapi import Depends, Header, Request

from server.errors import ApiError
from server.services import Services
from server.sessions import SessionManager
from server.settings import Settings
from server.simulations import SimulationPool
from server.storage import ManeuverStore

TOKEN_HEADER = "X-Footfall-Token"


async def get_services(request: Request) -> Services:
    return request.app.state.services  # type: ignore[no-any-return]


ServicesDep = Annotated[Services, Depends(get_services)]


async def get_settings(services: ServicesDep) -> Settings:
    return services.settings


async def get_store(services: ServicesDep) -> ManeuverStore:
    return services.store


async def get_sessions(services: ServicesDep) -> SessionManager:
    return services.sessions


async def get_simulations(services: ServicesDep) -> SimulationPool:
    return services.simulations


SettingsDep = Annotated[Settings, Depends(get_settings)]
StoreDep = Annotated[ManeuverStore, Depends(get_store)]
SessionsDep = Annotated[SessionManager, Depends(get_sessions)]
SimulationsDep = Annotated[SimulationPool, Depends(get_simulations)]


def check_token(settings: Settings, presented: str | None) -> None:
    """Raises ApiError 401/403 unless writes are open or `presented` is the API token."""
    if not settings.token_required:
        return
    if settings.api_token is None:
        raise ApiError(403, "writes are disabled: the server is bound beyond loopback without FOOTFALL_API_TOKEN",
                       [{"field": TOKEN_HEADER, "reason": "no token configured on the server"}])  # fmt: skip
    if not presented:
        raise ApiError(401, f"this request writes or drives: send the API token in the {TOKEN_HEADER} header",
                       [{"field": TOKEN_HEADER, "reason": "is required"}],
                       headers={"WWW-Authenticate": f'Bearer realm="footfall", header="{TOKEN_HEADER}"'})  # fmt: skip
    if not secrets.compare_digest(presented.encode("utf-8", "replace"), settings.api_token.encode("utf-8")):
        raise ApiError(403, "the API token is wrong", [{"field": TOKEN_HEADER, "reason": "does not match"}])


async def require_write(
    settings: SettingsDep,
    x_footfall_token: Annotated[str | None, Header(include_in_schema=False)] = None,
    authorization: Annotated[str | None, Header(include_in_schema=False)] = None,
) -> None:
    """Lets the request through when writes are open or it carries the token (header or `Bearer`)."""
    presented = x_footfall_token or None  # an empty header does not hide a Bearer token
    if presented is None and authorization and authorization.lower().startswith("bearer "):
        presented = authorization[7:].strip()
    check_token(settings, presented)


WriteAccess = Depends(require_write)
