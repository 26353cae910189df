"""The studio's robot picker: a "robot" dropdown (Drive tab) listing the robots GET /robots lists; choosing one
resets the tab's live session on that robot (the scene is redrawn from the new simulation's visuals)."""

from __future__ import annotations

from typing import Any

from server.errors import ApiError
from server.robots import list_robots, name_of, resolve_robot
from server.sessions import SessionError


def current_robot(tab: Any) -> str:
    """Gives the listed name of the robot the tab's session runs (the server's default without a session)."""
    settings = tab.services.settings
    s = tab.session
    return name_of(s.robot if s is not None else settings.robot, settings)


def picked_load(tab: Any) -> str:
    """Gives what a simulation loads for the tab's picked robot (its session's; the server's without a session):
    the Author tab's Validate and physics check use it."""
    s = tab.session
    return str(s.robot if s is not None else tab.services.settings.robot)


def use_robot(tab: Any, name: str) -> bool:
    """Resets the tab's session on the robot `name` (REST rules: a listed name, loaded once); False, with a
    notification saying why, when it cannot be used."""
    s = tab.session
    if s is None or not tab.authorized("change the robot"):
        return False
    try:
        load = resolve_robot(name, tab.services.settings)
        s.reset(robot=load)
    except ApiError as e:
        tab.notify("Robot not usable", e.detail, "red")
        return False
    except SessionError as e:
        tab.notify("Robot not usable", e.message, "red")
        return False
    tab.zero_sliders()  # a new robot starts standing: the old command must not walk it off
    return True


def add_robot_picker(tab: Any) -> Any:
    """Adds the "robot" dropdown to the tab's current GUI container; returns its handle."""
    names = [str(e["name"]) for e in list_robots(tab.services.settings)]
    current = current_robot(tab)
    if current not in names:
        names.append(current)
    dd = tab.client.gui.add_dropdown("robot", tuple(names), initial_value=current)
    editor = getattr(tab, "editor", None)
    if editor is not None:
        editor.robot_load = lambda: picked_load(tab)  # validate for the robot the tab drives

    @dd.on_update
    def _(e: Any) -> None:
        want = str(e.target.value)
        if tab.session is None or want == current_robot(tab):
            return
        if not use_robot(tab, want):
            dd.value = current_robot(tab)  # back to what runs

    return dd


__all__ = ["add_robot_picker", "current_robot", "picked_load", "use_robot"]
