"""The REST routes, one module per resource, gathered into one router."""

from fastapi import APIRouter

from server.api import health, maneuvers, robots, sessions, simulations, studio, sweeps, terrains

api_router = APIRouter()
api_router.include_router(health.router)
api_router.include_router(maneuvers.router)
api_router.include_router(simulations.router)
api_router.include_router(sessions.router)
api_router.include_router(studio.router)
api_router.include_router(terrains.router)
api_router.include_router(sweeps.router)
api_router.include_router(robots.router)

__all__ = ["api_router"]
