"""/docs, /redoc and /favicon.ico are served from the installed packages: nothing they load leaves the server."""

from __future__ import annotations

import re

from fastapi.testclient import TestClient


def _loaded_urls(html: str) -> list[str]:
    return re.findall(r'(?:src|href)="([^"]+)"', html)


def test_docs_and_redoc_load_only_local_assets(client: TestClient) -> None:
    for page, wanted in (("/docs", "SwaggerUIBundle"), ("/redoc", "<redoc")):
        r = client.get(page)
        assert r.status_code == 200 and wanted in r.text, page
        urls = _loaded_urls(r.text)
        assert urls and all(u.startswith("/") for u in urls), (page, urls)
        assert "fonts.googleapis" not in r.text and "cdn" not in r.text.lower()
        for u in urls:
            a = client.get(u)
            assert a.status_code == 200, u
            if u.endswith(".js"):
                assert len(a.content) > 100_000, u  # the real bundle, not a stub
    assert client.get("/docs/oauth2-redirect").status_code == 200


def test_favicon(client: TestClient) -> None:
    r = client.get("/favicon.ico")
    assert r.status_code == 200 and r.headers["content-type"].startswith("image/") and b"<svg" in r.content
    assert 'rel="icon"' in client.get("/").text
