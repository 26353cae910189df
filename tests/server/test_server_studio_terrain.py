"""The studio's custom terrain: a terrain with parameters or an uploaded file puts the tab's robot on it; what the
REST API refuses (a server path, a bad key) the studio refuses too, and the robot stays where it was."""

from __future__ import annotations

import io
from typing import Any

import numpy as np
from fastapi.testclient import TestClient
from test_server_studio import studio_app, tab, wait_for  # noqa: F401 - fixtures

from server.terrains import terrain_dir


def test_a_tab_uses_a_custom_terrain(studio_app: tuple[TestClient, Any], tab: Any) -> None:  # noqa: F811
    client, services = studio_app
    notes: list[tuple[str, str]] = []
    tab.notify = lambda title, body, color="blue": notes.append((title, body))
    assert tab.use_terrain("stairs:riser_m=0.18,tread_m=0.28")
    assert tab.session.terrain == "stairs:riser_m=0.18,tread_m=0.28"
    for bad in ("/etc/passwd.xml", "stairs:riser=0.18", "nothere.npy:cell_m=0.05"):
        assert not tab.use_terrain(bad)
        assert tab.session.terrain == "stairs:riser_m=0.18,tread_m=0.28"
    assert [t for t, _ in notes] == ["Terrain not usable"] * 3
    assert "over the network a file is one uploaded" in notes[0][1] and "valid: x_start_m" in notes[1][1]
    buf = io.BytesIO()
    np.save(buf, np.full((10, 20), 0.05))
    assert client.put("/terrain-files/slab.npy", content=buf.getvalue()).status_code == 201
    assert tab.use_terrain("slab.npy:cell_m=0.05")
    assert tab.session.terrain == f"{terrain_dir(services.settings) / 'slab.npy'}:cell_m=0.05"
    # the view is rebuilt on the new terrain: the slab's geom is drawn
    assert wait_for(lambda: any("heightmap" in g.name for g in tab.session.sim.visuals().terrain_geoms), 10.0)
