"""/docs (Swagger UI), /redoc and /favicon.ico served from the installed packages: the API docs work offline.

FastAPI's own /docs and /redoc pages load their scripts from a CDN, so on a machine without internet they stay
blank. The assets come from the `fastapi-offline` package (Swagger UI's bundle and CSS, ReDoc's standalone script),
served under /docs-assets; the favicon is the project's own (web/favicon.svg).
"""

from __future__ import annotations

from pathlib import Path

from fastapi import FastAPI
from fastapi.openapi.docs import get_redoc_html, get_swagger_ui_html, get_swagger_ui_oauth2_redirect_html
from fastapi.responses import FileResponse, HTMLResponse
from fastapi.staticfiles import StaticFiles

ASSETS_URL = "/docs-assets"
FAVICON = Path(__file__).resolve().parents[1] / "web" / "favicon.svg"


def assets_dir() -> Path:
    """Returns the folder holding swagger-ui-bundle.js, swagger-ui.css and redoc.standalone.js."""
    import fastapi_offline

    return Path(fastapi_offline.__file__).resolve().parent / "static"


def install(app: FastAPI) -> None:
    """Adds /docs, /docs/oauth2-redirect, /redoc, the assets they load and /favicon.ico to an app created with
    docs_url=None and redoc_url=None."""
    app.mount(ASSETS_URL, StaticFiles(directory=assets_dir()), name="docs-assets")
    title = app.title

    @app.get("/docs", include_in_schema=False)
    def swagger_ui() -> HTMLResponse:
        return get_swagger_ui_html(
            openapi_url=app.openapi_url or "/openapi.json", title=f"{title} — API",
            swagger_js_url=f"{ASSETS_URL}/swagger-ui-bundle.js", swagger_css_url=f"{ASSETS_URL}/swagger-ui.css",
            swagger_favicon_url="/favicon.ico", oauth2_redirect_url="/docs/oauth2-redirect",
        )  # fmt: skip

    @app.get("/docs/oauth2-redirect", include_in_schema=False)
    def swagger_redirect() -> HTMLResponse:
        return get_swagger_ui_oauth2_redirect_html()

    @app.get("/redoc", include_in_schema=False)
    def redoc() -> HTMLResponse:
        return get_redoc_html(
            openapi_url=app.openapi_url or "/openapi.json", title=f"{title} — API",
            redoc_js_url=f"{ASSETS_URL}/redoc.standalone.js", redoc_favicon_url="/favicon.ico",
            with_google_fonts=False,
        )  # fmt: skip

    @app.get("/favicon.ico", include_in_schema=False)
    def favicon() -> FileResponse:
        return FileResponse(FAVICON, media_type="image/svg+xml")
