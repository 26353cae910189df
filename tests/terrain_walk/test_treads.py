"""Tread-by-tread footholds on stairs (planning.terrain.treads): risers read off a height profile, landing windows
by what bounds each tread, the tread a swing lands on, and the swing maps that carry a nosing forward."""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest

from planning.robot import load_robot
from planning.sim.world import RobotState
from planning.terrain.maps import maps_from_grids
from planning.terrain.navigate import NavigatorParams, TerrainNavigator
from planning.terrain.treads import (
    TreadMargins,
    choose_tread,
    clear_of_nosing,
    shin_clearance,
    shin_ground,
    tread_line,
)

RES = 0.03
HEADING = np.array([1.0, 0.0])


def _profile(x_risers: tuple[float, ...], rise: float, u0: float = -0.8, n: int = 100) -> np.ndarray:
    """Heights sampled every RES m from u0 along +x; a riser at each x (rise > 0 up, < 0 down)."""
    u = u0 + np.arange(n) * RES
    return np.asarray(sum(np.where(u >= x, rise, 0.0) for x in x_risers) + 0.0 * u, dtype=np.float64)


def test_tread_line_finds_each_riser_within_a_cell_and_its_sign() -> None:
    risers = (0.5, 0.8, 1.1)
    up = tread_line(_profile(risers, 0.15), -0.8, RES, 0.08, np.zeros(2), HEADING)
    assert up.risers.size == 3 and np.all(up.signs > 0)
    assert np.max(np.abs(up.risers - np.array(risers))) <= RES
    down = tread_line(_profile(risers, -0.15), -0.8, RES, 0.08, np.zeros(2), HEADING)
    assert down.risers.size == 3 and np.all(down.signs < 0)
    # a 5 cm curb is no riser at 8 cm; flat ground has none
    assert tread_line(_profile((0.5,), 0.05), -0.8, RES, 0.08, np.zeros(2), HEADING).risers.size == 0
    assert tread_line(np.zeros(50), -0.8, RES, 0.08, np.zeros(2), HEADING).risers.size == 0


def test_windows_keep_the_toe_off_a_riser_ahead_and_the_shin_off_a_nosing_behind() -> None:
    m = TreadMargins()
    up = tread_line(_profile((0.5, 0.8, 1.1), 0.15), -0.8, RES, 0.08, np.zeros(2), HEADING)
    r = up.risers
    lo, hi = up.window(1, m)  # the first tread going up: a drop behind, a riser ahead
    assert lo == pytest.approx(r[0] + m.drop_behind_m) and hi == pytest.approx(r[1] - m.riser_ahead_m)
    lo0, hi0 = up.window(0, m)  # the floor before the stairs: open behind
    assert lo0 == -np.inf and hi0 == pytest.approx(r[0] - m.riser_ahead_m)
    down = tread_line(_profile((0.5, 0.8, 1.1), -0.15), -0.8, RES, 0.08, np.zeros(2), HEADING)
    lo, hi = down.window(1, m)  # going down: the nosing behind is higher (the shin), the drop ahead lower
    assert lo == pytest.approx(down.risers[0] + m.riser_behind_m)
    assert hi == pytest.approx(down.risers[1] - m.drop_ahead_m)
    # a tread too short for its margins gives its middle
    short = tread_line(_profile((0.5, 0.62), 0.15), -0.8, RES, 0.08, np.zeros(2), HEADING)
    lo, hi = short.window(1, m)
    mid = 0.5 * (short.risers[0] + short.risers[1])
    assert lo < mid < hi and hi - lo == pytest.approx(m.min_width_m)


def test_a_swing_lands_on_its_own_tread_or_the_next_never_skipping_one() -> None:
    m = TreadMargins()
    line = tread_line(_profile((0.5, 0.8, 1.1, 1.4), 0.15), -0.8, RES, 0.08, np.zeros(2), HEADING)
    foot = 0.62  # on the first tread
    lo1, hi1 = line.window(1, m)
    lo2, hi2 = line.window(2, m)
    # a nominal inside the next tread's window is kept as it is
    assert choose_tread(line, foot, 0.9, m) == pytest.approx(0.9)
    # a nominal on the nosing band of the next tread goes to the nearer window end
    u = choose_tread(line, foot, 0.79, m)
    assert u in (pytest.approx(hi1), pytest.approx(lo2))
    assert abs(u - 0.79) == pytest.approx(min(abs(hi1 - 0.79), abs(lo2 - 0.79)))
    # two treads ahead is too far: the next tread's far end, not a skipped tread
    assert choose_tread(line, foot, 1.25, m) == pytest.approx(hi2)
    # a nominal behind the foot's own tread stays on it
    assert choose_tread(line, foot, 0.3, m) == pytest.approx(lo1)
    # every landing is inside a window, whatever the nominal
    for nominal in np.linspace(0.0, 1.6, 60):
        u = choose_tread(line, foot, float(nominal), m)
        seg = line.segment(u)
        lo, hi = line.window(seg, m)
        assert lo - 1e-9 <= u <= hi + 1e-9 and seg in (1, 2)


def test_shin_ground_carries_a_nosing_forward_over_the_tread_below_only() -> None:
    xs = -1.0 + np.arange(120) * RES
    ys = -0.6 + np.arange(40) * RES
    # a landing at 0.6 m dropping to 0.45 m at x = 0.5 (going +x)
    h = np.where(xs < 0.5, 0.6, 0.45)[:, None] * np.ones((1, ys.size))
    maps = maps_from_grids((xs[0], ys[0]), RES, h, np.zeros(h.shape, bool))
    out = shin_ground(maps, HEADING, 0.10)
    g = out.ground_height[:, 20]
    assert np.all(g[xs < 0.5 - RES] == pytest.approx(0.6))  # the landing itself is unchanged
    edge = xs[g > 0.59].max() + RES / 2  # the high ground's end, was at 0.5
    assert 0.10 - 1e-9 <= edge - 0.5 <= 0.10 + RES + 1e-9
    assert np.all(g[xs > edge] == pytest.approx(0.45))
    # going the other way (up the step) nothing changes: the high side is already behind the riser
    back = shin_ground(maps, -HEADING, 0.10).ground_height[:, 20]
    assert np.allclose(
        back[(xs < 0.5 - 0.12) | (xs > 0.5 + RES)], h[(xs < 0.5 - 0.12) | (xs > 0.5 + RES), 20]
    )
    # the input maps are left as they were
    assert np.array_equal(maps.ground_height, h)


def _pacer(feet_x: list[float], held: dict[int, float] | None = None):
    """TerrainNavigator._tread_pace on a stand-in navigator facing +x at the origin, feet at feet_x (FL, FR, RL,
    RR), swings' chosen touchdowns at held (leg → x)."""

    robot = load_robot("spot")
    line = tread_line(_profile((0.5, 0.8), 0.15), -0.8, RES, 0.08, np.zeros(2), HEADING)
    t = np.full(4, np.nan)
    p = np.full((4, 3), np.nan)
    for leg, x in (held or {}).items():
        t[leg], p[leg] = 1.0, (x, 0.0, 0.0)
    nav = SimpleNamespace(
        params=NavigatorParams(),
        _tread_lines=(line, line),
        climb_speed=0.375,
        _tread_t=t,
        _tread_p=p,
        p_body_hip_xy=np.asarray(robot.p_body_hip, dtype=float)[:, :2],
    )
    s = RobotState()
    s.p_world_foot[:, 0] = feet_x
    s.p_world_foot[:, 1] = [0.165, -0.165, 0.165, -0.165]
    return TerrainNavigator._tread_pace(nav, s)  # type: ignore[arg-type]


def test_the_body_is_paced_by_its_feet_on_stairs() -> None:
    # feet under the hips: the climb speed as it is
    assert _pacer([0.3, 0.3, -0.3, -0.3]) == pytest.approx(1.0)
    # feet (or a swing's chosen touchdown) ahead of the body: faster, within the range's top
    assert 1.0 < _pacer([0.3, 0.3, -0.3, -0.3], held={0: 0.6}) <= NavigatorParams().stairs.pace_range[1]
    # a hind foot trailing its hip by more than pace_lag_m: slower, down to a stop
    slow = _pacer([0.3, 0.3, -0.3, -0.55])
    assert 0.0 <= slow < 1.0
    assert _pacer([0.3, 0.3, -0.3, -0.9]) == pytest.approx(0.0)


L_UPPER, L_LOWER = 0.32, 0.34  # the robot's thigh and shin (m)


def _brute_shin_distance(hip: np.ndarray, foot: np.ndarray, point: np.ndarray) -> float:
    """The knee found by sweeping the thigh's angle (the place l_lower from the foot, behind the hip-foot line),
    then the point's distance to the shin sampled densely."""
    a = np.linspace(-np.pi, np.pi, 200001)
    knees = hip + L_UPPER * np.stack([np.cos(a), np.sin(a)], 1)
    err = np.abs(np.hypot(*(knees - foot).T) - L_LOWER)
    d = foot - hip
    behind = (d[0] * (knees[:, 1] - hip[1]) - d[1] * (knees[:, 0] - hip[0])) * np.sign(d[1]) > 0
    err[~behind] = np.inf
    knee = knees[int(np.argmin(err))]
    t = np.linspace(0.0, 1.0, 4001)[:, None]
    return float(np.min(np.hypot(*(knee + t * (foot - knee) - point).T)))


def test_shin_clearance_is_the_nosings_distance_to_the_shin_of_a_knee_back_leg() -> None:
    """Against a brute-force knee (thigh angle swept) and a densely sampled shin; out of reach gives -inf."""
    hip = np.array([0.05, 0.58])
    nosing = np.array([0.0, 0.15])
    feet = np.array([[0.10, 0.0], [0.17, 0.0], [0.25, 0.0], [0.05, 0.2]])
    got = shin_clearance(hip, feet, nosing, L_UPPER, L_LOWER)
    for foot, g in zip(feet, got, strict=True):
        assert g == pytest.approx(_brute_shin_distance(hip, foot, nosing), abs=2e-3)
    assert shin_clearance(hip, np.array([[0.9, 0.0]]), nosing, L_UPPER, L_LOWER)[0] == -np.inf
    # the knee points back: a foot landing just ahead of the nosing below a hip over it has its shin across the
    # nosing; landing farther ahead (the leg reaching forward) lifts the shin clear of it
    assert got[0] < 0.03 < got[2]


def test_a_foot_stepping_down_moves_along_its_tread_until_its_shin_clears_the_nosing() -> None:
    hip = np.array([0.05, 0.58])  # (along the heading, up) with the nosing at (0, 0.15), the tread at 0
    nosing = np.array([0.0, 0.15])
    window = (0.12, 0.23)
    u = clear_of_nosing(0.12, window, hip, 0.0, nosing, L_UPPER, L_LOWER, 0.07)
    c = shin_clearance(hip, np.array([[u, 0.0]]), nosing, L_UPPER, L_LOWER)[0]
    assert window[0] < u <= window[1] and c >= 0.07
    # the nearest such place: 1 cm less and the shin is closer than wanted
    assert shin_clearance(hip, np.array([[u - 0.01, 0.0]]), nosing, L_UPPER, L_LOWER)[0] < 0.07
    # a place that clears already stays where it is
    assert clear_of_nosing(0.22, window, hip, 0.0, nosing, L_UPPER, L_LOWER, 0.07) == pytest.approx(0.22)
    # with no place in the window clear enough (a low hip), the place of the most clearance
    low = np.array([0.05, 0.45])
    v = clear_of_nosing(0.12, window, low, 0.0, nosing, L_UPPER, L_LOWER, 0.07)
    cands = np.arange(window[0], window[1] + 1e-9, 0.01)
    best = shin_clearance(low, np.stack([cands, np.zeros_like(cands)], 1), nosing, L_UPPER, L_LOWER)
    assert shin_clearance(low, np.array([[v, 0.0]]), nosing, L_UPPER, L_LOWER)[0] == pytest.approx(best.max())
