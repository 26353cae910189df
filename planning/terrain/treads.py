"""Footholds on stairs chosen tread by tread.

On a flight of stairs the step-obstacle map leaves a narrow free window on each tread, and a foothold chosen cell
by cell (the capture-point selection, then the step QP) flips between two treads from one replan to the next, or is
pushed sideways toward the body's center line when the window ahead is tight. Here the ground along each foot's
line is read as segments between risers instead, and each swing lands on one tread chosen at liftoff:

- ``TreadLine``: the risers along one line (positions ``u`` in m along the heading from an origin, each rising or
  dropping) and, from them, the window of each segment where a foot may land: the segment shrunk by the toe's
  clearance from a riser in front, the shin's clearance from a nosing behind going down, and the foot's margin
  from a drop-off edge;
- ``choose_tread``: the window a swing lands in: the one nearest the nominal foothold among the foot's own segment
  and the next one along the heading (never skipping a tread), the nominal clamped into it.

The navigator (planning.terrain.navigate) builds the lines at its perception rate and applies them to the swinging
feet's touchdowns in its stairs mode.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from planning.terrain.maps import TerrainMaps


@dataclass(frozen=True)
class TreadMargins:
    """How far a foothold's center stays from the ends of its segment (m), by what lies there.

    riser_ahead_m: a riser in front (ground higher ahead): the toe and the swing's descent clear it;
    riser_behind_m: a riser behind (ground higher behind, going down): the stance shin clears its nosing;
    drop_ahead_m, drop_behind_m: a drop-off in front or behind (ground lower there): the foot sphere stays on the
    tread (10 cm in front: the sensor's ground-height map puts a drop-off's edge up to a cell late, where the
    upper tread's height bleeds over it, and at 7 cm a foot stepping down landed 2.5 cm from the real edge). A
    window narrower than min_width_m is replaced by the segment's middle (min_width_m wide).
    """

    riser_ahead_m: float = 0.08
    riser_behind_m: float = 0.12
    drop_ahead_m: float = 0.10
    drop_behind_m: float = 0.06
    min_width_m: float = 0.02


@dataclass(frozen=True)
class TreadLine:
    """The risers along one foot line: origin (2,) m world and heading (2,) unit vector of the line; risers (R,)
    m along it from the origin, increasing; signs (R,) +1 where the ground rises along the heading, -1 where it
    drops. Segment i lies between risers i-1 and i (segment 0 before the first, segment R after the last)."""

    origin: NDArray[np.float64]
    heading: NDArray[np.float64]
    risers: NDArray[np.float64]
    signs: NDArray[np.float64]

    def u(self, xy: NDArray[np.float64]) -> NDArray[np.float64]:
        """Gives the positions (..) m along the line of world points xy (.., 2)."""
        return np.asarray((np.asarray(xy, dtype=np.float64) - self.origin) @ self.heading, dtype=np.float64)

    def segment(self, u: float) -> int:
        """Gives the segment index of position u (m along the line)."""
        return int(np.searchsorted(self.risers, u))

    def window(self, i: int, m: TreadMargins) -> tuple[float, float]:
        """Gives the landing window (lo, hi) m along the line of segment i (unbounded ends are ±inf)."""
        R = self.risers.size
        lo, hi = -np.inf, np.inf
        if i > 0:
            lo = float(self.risers[i - 1]) + (m.drop_behind_m if self.signs[i - 1] > 0 else m.riser_behind_m)
        if i < R:
            hi = float(self.risers[i]) - (m.riser_ahead_m if self.signs[i] > 0 else m.drop_ahead_m)
        if hi - lo < m.min_width_m:
            a = float(self.risers[i - 1]) if i > 0 else hi
            b = float(self.risers[i]) if i < R else lo
            mid = 0.5 * (a + b)
            lo, hi = mid - 0.5 * m.min_width_m, mid + 0.5 * m.min_width_m
        return lo, hi


def risers_along(
    row: NDArray[np.float64], res: float, rise_m: float
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Gives the risers along one height profile row (N,) sampled every res m — where the height changes by more
    than rise_m within two samples, runs of such samples counting once — as their centers (m from the profile's
    second sample) and signs (+1 rising, -1 dropping, the run's largest change). Unknown (NaN) heights are none."""
    dz = row[2:] - row[:-2]  # centered on samples 1..N-2
    idx = np.flatnonzero(np.abs(dz) > rise_m)
    if idx.size == 0:
        return np.zeros(0), np.zeros(0)
    starts = idx[np.r_[True, np.diff(idx) > 1]]
    ends = idx[np.r_[np.diff(idx) > 1, True]]
    sign = np.sign(
        [dz[a : b + 1][np.argmax(np.abs(dz[a : b + 1]))] for a, b in zip(starts, ends, strict=True)]
    )
    return np.asarray(0.5 * (starts + ends) * res, dtype=np.float64), np.asarray(sign, dtype=np.float64)


def tread_line(
    row: NDArray[np.float64],
    u0: float,
    res: float,
    rise_m: float,
    origin: NDArray[np.float64],
    heading: NDArray[np.float64],
) -> TreadLine:
    """Gives the TreadLine of one height profile row (N,) (m; NaN unknown) sampled every res m from u0 m along
    heading from origin, its risers found by risers_along. (dz[i] spans samples i..i+2: a step between samples j
    and j+1 lights dz[j-1] and dz[j], a run centered on sample j + 1/2, which risers_along counts from the
    second sample.)"""
    centers, signs = risers_along(np.asarray(row, dtype=np.float64), res, rise_m)
    return TreadLine(
        np.asarray(origin, dtype=np.float64).copy(),
        np.asarray(heading, dtype=np.float64).copy(),
        u0 + res + centers,
        signs,
    )


def choose_tread(line: TreadLine, u_foot: float, u_nominal: float, margins: TreadMargins) -> float:
    """Gives where along the line (m) a swing from u_foot toward the nominal foothold u_nominal lands: in the
    window of the foot's own segment or the next one along the heading (the nearer to u_nominal; a foot never
    skips a tread, nor steps back one), u_nominal clamped into it."""
    i = line.segment(u_foot)
    best_u, best_d = u_nominal, np.inf
    for j in (i, i + 1):
        if j > line.risers.size:
            continue
        lo, hi = line.window(j, margins)
        u = float(np.clip(u_nominal, lo, hi))
        d = abs(u - u_nominal)
        if d < best_d - 1e-9:
            best_u, best_d = u, d
    return best_u


def shin_ground(maps: TerrainMaps, heading: NDArray[np.float64], reach_m: float) -> TerrainMaps:
    """Gives the maps with each cell's ground raised to the highest ground within reach_m behind it along heading
    (a unit vector), cell by cell: a drop's upper edge carried reach_m forward (rounded up to whole cells). A swing planned over it keeps a foot
    stepping down high until it is reach_m past the nosing, where its shin, which trails behind and above the foot,
    clears the nosing too."""
    res = maps.resolution_m
    n = int(np.ceil(reach_m / res - 1e-9))
    if n <= 0:
        return maps
    src = maps.ground_height
    g = src.copy()
    nx, ny = src.shape
    done: set[tuple[int, int]] = set()
    for k in range(1, n + 1):
        d = k * res  # at least reach_m in all: cells carry whole
        i, j = int(round(d * heading[0] / res)), int(round(d * heading[1] / res))
        if (i, j) in done or (i, j) == (0, 0):
            continue
        done.add((i, j))
        # g[x] = max(g[x], src[x - (i, j)]) where both lie on the grid
        a0, a1 = max(i, 0), nx + min(i, 0)
        b0, b1 = max(j, 0), ny + min(j, 0)
        np.fmax(g[a0:a1, b0:b1], src[a0 - i : a1 - i, b0 - j : b1 - j], out=g[a0:a1, b0:b1])
    return dataclasses.replace(maps, ground_height=g)


def shin_clearance(
    hip: NDArray[np.float64],
    feet: NDArray[np.float64],
    point: NDArray[np.float64],
    l_upper: float,
    l_lower: float,
) -> NDArray[np.float64]:
    """Gives the distance (m) from a point (a nosing) to the shin, the segment from the knee to the foot, for a leg
    whose hip is at hip (2,) and whose foot is at each of feet (K, 2), all (along the heading, up) in m in the
    leg's plane, the knee behind the hip-foot line (a knee that points back); -inf where the foot is out of reach.
    """
    hip = np.asarray(hip, dtype=np.float64)
    d = np.asarray(feet, dtype=np.float64) - hip
    D = np.hypot(d[:, 0], d[:, 1])
    reach = (D < l_upper + l_lower - 1e-3) & (D > abs(l_upper - l_lower) + 1e-3)
    Ds = np.where(reach, D, 1.0)
    a = (l_upper**2 - l_lower**2 + Ds**2) / (2.0 * Ds)
    h = np.sqrt(np.maximum(l_upper**2 - a**2, 0.0))
    e = d / Ds[:, None]
    perp = np.stack([-e[:, 1], e[:, 0]], axis=1)
    perp *= np.where(perp[:, 0] > 0.0, -1.0, 1.0)[:, None]  # toward the back
    knee = hip + a[:, None] * e + h[:, None] * perp
    shin = feet - knee
    t = np.clip(
        np.sum((point - knee) * shin, axis=1) / np.maximum(np.sum(shin * shin, axis=1), 1e-12), 0.0, 1.0
    )
    dist = np.hypot(*(point - (knee + t[:, None] * shin)).T)
    return np.where(reach, dist, -np.inf)


def clear_of_nosing(
    u: float,
    window: tuple[float, float],
    hip: NDArray[np.float64],
    foot_z: float,
    nosing: NDArray[np.float64],
    l_upper: float,
    l_lower: float,
    clear_m: float,
) -> float:
    """Gives where along a tread (m) a foot stepping down lands so that its shin clears the nosing it stepped over
    by clear_m (see shin_clearance): u itself if it does, else the nearest place in the window (lo, hi) that does,
    else the place of the most clearance (u when none is in reach). hip (2,): where the hip will be at touchdown;
    foot_z: the foot center's height on the tread; nosing (2,): the nosing's place, all (along the heading, up)."""
    lo, hi = window
    cands = np.arange(lo, hi + 1e-9, 0.01)
    if cands.size == 0:
        return u
    places = np.append(cands, u)  # the window's places and u itself, in one call
    feet = np.stack([places, np.full(places.size, foot_z)], axis=1)
    c_all = shin_clearance(hip, feet, np.asarray(nosing, dtype=np.float64), l_upper, l_lower)
    if c_all[-1] >= clear_m:
        return u
    c = c_all[:-1]
    good = c >= clear_m
    if np.any(good):
        return float(cands[good][np.argmin(np.abs(cands[good] - u))])
    if not np.isfinite(np.max(c)):
        return u
    return float(cands[int(np.argmax(c))])
