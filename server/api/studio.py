"""The landing page (GET /), the studio's whereabouts (GET /studio) and 'preview this in the studio'."""

from __future__ import annotations

import html
import time
from pathlib import Path
from typing import Any

from fastapi import APIRouter
from fastapi.responses import HTMLResponse, JSONResponse

from server.deps import ServicesDep, WriteAccess
from server.errors import ApiError
from server.schemas import StudioPreviewIn
from server.terrains import resolve_terrain

router = APIRouter(tags=["studio"])
WEB_DIR = Path(__file__).resolve().parents[2] / "web"
PREVIEW_TTL_S = 60.0  # a studio tab opened within this long after the request picks the preview up


@router.get("/", response_class=HTMLResponse, include_in_schema=False)
def landing(services: ServicesDep) -> HTMLResponse:
    page = WEB_DIR / "index.html"
    try:
        text = page.read_text(encoding="utf-8")
    except OSError:
        text = "<!doctype html><title>footfall</title><h1>footfall</h1><p>See <a href='/docs'>/docs</a>.</p>"
    port = services.studio.port if services.studio is not None else services.settings.viewer_port
    text = text.replace("{{VIEWER_PORT}}", html.escape(str(port)))
    text = text.replace("{{TOKEN_REQUIRED}}", "true" if services.settings.token_required else "false")
    return HTMLResponse(text)


@router.get("/studio", summary="Where the studio (viser) listens, its clients and their frame rates")
def studio_info(services: ServicesDep) -> dict[str, Any]:
    st = services.studio
    if st is None:
        return {"enabled": False, "port": None, "clients": 0, "fps": {}}
    return {"enabled": True, **st.info()}


@router.post(
    "/studio/preview",
    status_code=202,
    dependencies=[WriteAccess],
    summary="Ask the studio to open a library maneuver and preview it (picked up by the next studio tab)",
)
def studio_preview(body: StudioPreviewIn, services: ServicesDep) -> JSONResponse:
    services.store.get(body.maneuver)  # 404 for an unknown name
    if services.studio is None:
        raise ApiError(409, "the studio is not running (started with FOOTFALL_STUDIO=0)",
                       [{"field": "studio", "reason": "not running"}])  # fmt: skip
    terrain = resolve_terrain(str(body.terrain), services.settings)
    now = time.time()
    services.preview_requests[:] = [r for r in services.preview_requests if now - r[0] < PREVIEW_TTL_S][-20:]
    services.preview_requests.append((now, body.maneuver, terrain))
    return JSONResponse({"maneuver": body.maneuver, "terrain": body.terrain, "port": services.studio.port},
                        status_code=202)  # fmt: skip
