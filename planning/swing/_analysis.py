"""The detailed analysis: puts a candidate swing (horizontal path + vertical trajectory) in a tier of FIG. 3.

Terrain is an obstacle where it stands above the *reference surface*, the straight line between the lift-off and
touchdown heights along the swing's progress: flat ground and the surfaces the foot leaves from and lands on are
never obstacles, a box between them is. Other legs are segments from their foot center to their knee; the swing
foot keeps ``keepout_radius_m`` from them, its knee ``knee_keepout_m``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from planning.robot import RobotModel
from planning.swing._poly import Poly1D, sample_pair
from planning.swing.params import SwingParams
from planning.swing.policies import Hold, HPath, LegCtx, vertical, vertical_family
from planning.swing.types import BodyMotion, GroundHeightFn, Tier

_FEW_KNEES = 8  # up to this many knee samples, one float IK each beats the vectorized one
# ndarray.max()/.min() without the method's Python wrapper (the same reduction: the same result, NaN included)
_max, _min = np.maximum.reduce, np.minimum.reduce
_NO_SAMPLES = np.zeros(0, dtype=int)  # no knee samples (read-only)
_NO_SAMPLES.flags.writeable = False
_NO_FLOATS = np.zeros(0)  # a verdict's arrays before they are computed (read-only)
_NO_FLOATS.flags.writeable = False
_NO_BOOLS = np.zeros(0, dtype=bool)
_NO_BOOLS.flags.writeable = False
_DIRS = np.array([[math.cos(a), math.sin(a)] for a in np.linspace(0.0, 2.0 * math.pi, 8, endpoint=False)])


@dataclass(slots=True)
class OtherLeg:
    """Another leg as an obstacle: its foot centers at the swing's sample times and its shank vector."""

    leg: int
    foot_center: np.ndarray  # (K,3) or (1,3) world, m
    shank: np.ndarray  # (3,) knee − foot center, world, m
    xy_box: tuple[
        float, ...
    ] = ()  # x/y extent of the lower leg (x_min, x_max, y_min, y_max), m; computed if not given

    shank_f: tuple[float, float, float] = field(init=False)  # shank as floats

    def __post_init__(self) -> None:
        sx, sy, sz = self.shank.tolist()
        self.shank_f = (sx, sy, sz)
        if self.xy_box:
            return
        fc = self.foot_center
        if len(fc) == 1:
            x, y = float(fc[0, 0]), float(fc[0, 1])
            self.xy_box = (min(x, x + sx), max(x, x + sx), min(y, y + sy), max(y, y + sy))
        else:
            lo, hi = fc.min(axis=0), fc.max(axis=0)
            self.xy_box = (
                float(lo[0]) + min(sx, 0.0),
                float(hi[0]) + max(sx, 0.0),
                float(lo[1]) + min(sy, 0.0),
                float(hi[1]) + max(sy, 0.0),
            )


@dataclass(slots=True)
class LegProblem:
    """Everything about one swing leg that does not depend on the candidate policy (built once per tick)."""

    leg: int
    ctx: LegCtx
    cos_yaw: float
    sin_yaw: float
    ts: np.ndarray  # (K,) sample times, s
    p_start: np.ndarray  # (3,) world contact point
    v_start: np.ndarray  # (3,) world velocity
    p_target: np.ndarray  # (3,)
    z_aggressive: Poly1D
    z_ok: bool  # the most aggressive vertical policy arrives on time
    zs_aggressive: np.ndarray | None  # (K,) (None in a problem set up for the event-driven selection only)
    others: list[OtherLeg]
    hips: np.ndarray  # (3,3) world hip positions at the first, middle and last of ts
    ground: GroundHeightFn
    flat_height: float | None  # set when the ground is FlatGround
    body: BodyMotion
    previous_policy: str | None
    u_z_aggressive: float  # vertical undesirability of the most aggressive policy, added to every candidate
    z_ref: float  # lift-off height of this swing, m: vertical tops are measured from max(z_ref, touchdown z)
    xy_liftoff: np.ndarray | None = None  # (2,) lift-off place of this swing (None: the foot's place now), m
    z_ceiling: float = math.inf  # highest foot the leg can reach, m
    g_knee_max: float | None = None  # highest ground probed around the hips (filled on first use), m
    z_gentlest: Poly1D | None = None  # the gentlest vertical policy's trajectory (filled on first use)
    zs_gentlest: np.ndarray | None = None  # (K,) its samples
    z_gentlest_ok: bool = False  # it arrives on time
    poses: dict[int, tuple[np.ndarray, np.ndarray]] = field(default_factory=dict)  # body pose at ts[k], by k
    # the same poses as 12 floats (position, then the rotation row by row), by k
    pose_floats: dict[int, tuple[float, ...]] = field(default_factory=dict)
    # the same poses stacked, by the bytes of the sample indices they are for
    pose_stacks: dict[bytes, tuple[np.ndarray, np.ndarray]] = field(default_factory=dict)
    hold: Hold | None = None  # rise first: the foot waits in x and y until it clears the terrain ahead
    hip_z_min: float = math.inf  # lowest hip over the swing, m
    terrain_hit: bool = False  # a candidate analysed for this problem collided with the terrain
    z_v_z1: tuple[float, float, float] = (
        math.nan,
        math.nan,
        math.nan,
    )  # start height m, vertical velocity m/s, target height m


@dataclass(slots=True)
class Verdict:
    """The tier of one candidate, its tie-breaking key (lower wins) and what the vertical selection reuses."""

    tier: Tier
    key: tuple[float, ...]
    undesirability: float
    miss_m: float
    blame: int | None = None  # the other leg in the worst self-collision
    # (the empty defaults are shared read-only arrays: a verdict's arrays are replaced, never written into)
    xw: np.ndarray = field(default_factory=lambda: _NO_FLOATS)  # (K,) world x of the samples
    yw: np.ndarray = field(default_factory=lambda: _NO_FLOATS)
    g: np.ndarray = field(default_factory=lambda: _NO_FLOATS)  # (K,) ground height under the samples
    obstacle: np.ndarray = field(default_factory=lambda: _NO_BOOLS)  # (K,) ground is an obstacle
    ring_g: np.ndarray | None = None  # (K,R) highest obstacle ground on each probe ring (−inf: none)
    any_obstacle: bool = True  # obstacle.any() (False lets the vertical checks skip the scraping test)
    foot_self_sev: float = 0.0
    near_others: list[OtherLeg] = field(default_factory=list)  # other legs close enough to matter
    knee_idx: np.ndarray = field(default_factory=lambda: _NO_SAMPLES)  # samples where knees are checked
    knee_terrain: bool = False  # knees may reach the terrain here
    gentlest_foot_sev: float | None = None  # _foot_self's severity along this path with the gentlest policy
    knee_sev: tuple[float, float] = (
        0.0,
        0.0,
    )  # knee-terrain and knee-self intrusions with the aggressive policy
    flat_height: float | None = None  # the ground's height when it is FlatGround (g is that everywhere)


def undesirability_h(hp: HPath, params: SwingParams) -> float:
    """Horizontal undesirability: peak acceleration and velocity over their limits; the preferred policy is cheaper."""
    u = hp.peak_a / params.a_max_xy_mps2 + 0.5 * hp.peak_v / params.v_max_xy_mps
    if hp.name == params.preferred_policy:
        u -= params.preferred_bonus
    return u


def undesirability_z(z: Poly1D, height_m: float, params: SwingParams) -> float:
    """Vertical undesirability: peak acceleration, peak velocity and swing height over their limits."""
    return (
        z.peak_a / params.a_max_z_mps2
        + 0.5 * z.peak_v / params.v_max_up_mps
        + 0.5 * height_m / params.max_swing_height_m
    )


def limits_ok(hp: HPath, c: LegCtx) -> bool:
    """True when the path keeps the per-axis limits (a start already beyond them is allowed to slow down)."""
    v_allow = max(c.v_max, abs(c.v0[0]), abs(c.v0[1])) * (1.0 + 1e-6) + 1e-9
    return hp.peak_v <= v_allow and hp.peak_a <= c.a_max * (1.0 + 1e-6) + 1e-9


def miss_distance(hp: HPath, c: LegCtx) -> float:
    """Horizontal distance (m) between where the path is at touchdown time and the target."""
    return math.hypot(hp.x.position(c.t_end) - c.p1[0], hp.y.position(c.t_end) - c.p1[1])


def reaches(hp: HPath, c: LegCtx, params: SwingParams) -> bool:
    """True when the path rests on the target by touchdown time."""
    return hp.t_arrive <= c.t_end + 1e-6 and miss_distance(hp, c) <= params.xy_reach_tol_m


def _point_segment(p: np.ndarray, a: np.ndarray, s: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Distances (K,) from points p (K,3) to segments a→a+s (a: (K,3) or (1,3)); and the heights along s."""
    ss = float(s @ s)
    # np.minimum/np.maximum and sqrt(Σ d²): what np.clip and np.linalg.norm compute, without their overhead
    u = np.minimum(np.maximum(((p - a) @ s) / ss, 0.0), 1.0) if ss > 1e-12 else np.zeros(len(p))
    d = p - (a + u[:, None] * s)
    return np.sqrt(np.add.reduce(d * d, axis=1)), u


def _point_segment_f(p: list[float], a: list[float], s: tuple[float, float, float]) -> float:
    """_point_segment for one point p (3) and one segment a→a+s, in Python floats."""
    sx, sy, sz = s
    dx, dy, dz = p[0] - a[0], p[1] - a[1], p[2] - a[2]
    ss = sx * sx + sy * sy + sz * sz
    u = min(max((dx * sx + dy * sy + dz * sz) / ss, 0.0), 1.0) if ss > 1e-12 else 0.0
    ex, ey, ez = dx - u * sx, dy - u * sy, dz - u * sz
    return math.sqrt(ex * ex + ey * ey + ez * ez)


def _pose_floats(body: BodyMotion, t: float) -> tuple[float, ...]:
    """body.pose_at(t) as 12 floats (position, then the rotation row by row); without a yaw rate in Python floats
    (the same arithmetic as pose_at's arrays: p + v·dt element by element)."""
    if body.yaw_rate != 0.0:
        p_w, R = body.pose_at(t)
        return (*p_w.tolist(), *R.ravel().tolist())
    dt = t - body.t0
    px, py, pz = body.p_world_body.tolist()
    if dt != 0.0:
        vx, vy, vz = body.v_world_body.tolist()
        px, py, pz = px + vx * dt, py + vy * dt, pz + vz * dt
    return (px, py, pz, *body.R_world_body.ravel().tolist())


class Analyzer:
    """Puts candidates of one leg in tiers; holds the robot and parameters, no per-tick state."""

    def __init__(self, robot: RobotModel, params: SwingParams) -> None:
        self.robot = robot
        self.params = params
        self.r_foot = float(robot.foot_radius_m)
        # Largest hip-to-knee distance: bounds how low a knee can be.
        self.knee_reach = float(np.sqrt(robot.l_upper**2 + np.max(np.abs(robot.abd_offset)) ** 2))
        self.family = vertical_family(params)
        self._ring_radii = np.asarray(params.cliff_rings_m, dtype=float)
        self._ring_radii_f = self._ring_radii.tolist()
        self._ring_offsets = (self._ring_radii[:, None, None] * _DIRS[None, :, :]).reshape(-1, 2)  # (R·8, 2)
        self._ring_offsets_dr = np.ascontiguousarray(
            (_DIRS[:, None, :] * self._ring_radii[None, :, None]).reshape(-1, 2)
        )  # (8·R, 2), direction-major
        # the rings closer than the cliff margin: terrain hit on one of them fails the vertical check
        self._probe_offsets = np.vstack(
            (np.zeros((1, 2)), self._ring_offsets_dr)
        )  # the samples, then the rings
        # their x and y columns as (n,1) arrays of their own (a slice of a column costs as much as the addition)
        self._probe_dx, self._probe_dy = (
            np.ascontiguousarray(self._probe_offsets[:, i : i + 1]) for i in (0, 1)
        )
        self._ring_dx, self._ring_dy = (
            np.ascontiguousarray(self._ring_offsets_dr[:, i : i + 1]) for i in (0, 1)
        )
        self._n_cliff_rings = int(np.count_nonzero(self._ring_radii < params.cliff_margin_m))
        self._knee_idx_cache: dict[int, np.ndarray] = {}
        self._no_obstacle_cache: dict[int, np.ndarray] = {}
        self._flat_cache: dict[tuple[int, float], np.ndarray] = {}
        # per leg: the knee probe grid's fore-aft offsets (every ~4 cm) and its two lateral offsets (hip, foot)
        fore = np.linspace(-self.knee_reach, self.knee_reach, 17)
        self._knee_grid = [(fore, np.array([0.0, float(robot.abd_offset[leg])])) for leg in range(4)]
        self._knee_grid_flat = [(np.repeat(f, len(sd)), np.tile(sd, len(f))) for f, sd in self._knee_grid]

    # ---- geometry of one candidate ------------------------------------------------------------------------
    def world_xy(self, prob: LegProblem, hp: HPath) -> tuple[np.ndarray, np.ndarray]:
        hx, hy = sample_pair(hp.x, hp.y, prob.ts)
        c, s = prob.cos_yaw, prob.sin_yaw
        if s == 0.0 and c == 1.0:
            return hx, hy
        return c * hx - s * hy, s * hx + c * hy

    def _terrain(self, prob: LegProblem, xw: np.ndarray, yw: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Ground under the samples and which samples are over an obstacle (above the reference surface)."""
        if prob.flat_height is not None:
            g = self._flat(len(xw), prob.flat_height)
            return g, g  # flat ground is never an obstacle (analyze knows it: flat_height is set)
        g = np.asarray(prob.ground(xw, yw), dtype=float)
        p0, p1 = prob.p_start, prob.p_target
        d = p1[:2] - p0[:2]
        dd = float(d @ d)
        if dd > 1e-12:
            u = ((xw - p0[0]) * d[0] + (yw - p0[1]) * d[1]) / dd
            prog = np.minimum(np.maximum(u, 0.0), 1.0)  # np.clip, without its dispatch cost
        else:
            prog = np.linspace(0.0, 1.0, len(xw))
        h_ref = p0[2] + prog * (p1[2] - p0[2])
        return g, h_ref

    def _ring_ground(
        self, prob: LegProblem, xw: np.ndarray, yw: np.ndarray, h_ref: np.ndarray
    ) -> np.ndarray | None:
        """Highest obstacle ground (K,R) on each probe ring around the samples, or None on flat ground."""
        if prob.flat_height is not None:
            return None
        K, R = len(xw), len(self._ring_radii)
        px = (xw[:, None] + self._ring_offsets[None, :, 0]).ravel()
        py = (yw[:, None] + self._ring_offsets[None, :, 1]).ravel()
        gr = np.asarray(prob.ground(px, py), dtype=float).reshape(K, R, 8)
        gr = np.where(gr > (h_ref + self.params.obstacle_step_m)[:, None, None], gr, -np.inf)
        return gr.max(axis=2)

    def _terrain_and_rings(
        self, prob: LegProblem, xw: np.ndarray, yw: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """_terrain and _ring_ground (mapped ground) in one ground lookup: the ground (K,) under the samples, the
        height (K,) above which ground is an obstacle (the reference surface plus obstacle_step_m) and the highest
        obstacle ground (K,R) on each probe ring.

        The probes lie direction by direction, ring by ring, then sample by sample, so that the highest of the 8
        directions is a reduction over the outer axis (over the inner axis of 8 it costs several times more); the
        samples themselves come first (offset 0), all in one broadcast addition per axis."""
        K = len(xw)
        m = len(self._probe_dx) - 1  # 0, then the rings direction-major
        px = xw + self._probe_dx  # (1 + 8·R, K), C-contiguous: ravel is a view
        py = yw + self._probe_dy
        gall = np.asarray(prob.ground(px.ravel(), py.ravel()), dtype=float)
        g = gall[:K]
        h_obs = self._h_obs(prob, xw, yw)
        # the highest ground on each ring, where it is an obstacle (the max of the obstacle ground, as before)
        gr = _max(gall[K:].reshape(8, m // 8, K), axis=0)  # (R,K)
        ring_g = np.where(gr > h_obs, gr, -np.inf).T  # (K,R)
        if self.params.endpoint_zone_m is not None:
            g_end = self._at_endpoints(prob, xw, yw, g, ring_g)
            assert g_end is not None
            g = g_end
        return g, h_obs, ring_g

    def _ground_under(self, prob: LegProblem, xw: np.ndarray, yw: np.ndarray) -> np.ndarray:
        """The ground (K,) under the samples alone (mapped ground): _terrain_and_rings's first output."""
        g = np.asarray(prob.ground(xw, yw), dtype=float)
        if self.params.endpoint_zone_m is not None:
            g_end = self._at_endpoints(prob, xw, yw, g, None)
            assert g_end is not None
            g = g_end
        return g

    def _rings(self, prob: LegProblem, xw: np.ndarray, yw: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """_terrain_and_rings's obstacle height (K,) and ring ground (K,R), the rings looked up on their own (the
        same probes, the same arithmetic)."""
        K = len(xw)
        off = self._ring_offsets_dr  # (8·R, 2), direction-major
        px = xw + self._ring_dx  # (8·R, K)
        py = yw + self._ring_dy
        gr_all = np.asarray(prob.ground(px.ravel(), py.ravel()), dtype=float)
        h_obs = self._h_obs(prob, xw, yw)
        gr = _max(gr_all.reshape(8, len(off) // 8, K), axis=0)  # (R,K)
        ring_g = np.where(gr > h_obs, gr, -np.inf).T  # (K,R)
        if self.params.endpoint_zone_m is not None:
            self._at_endpoints(prob, xw, yw, None, ring_g)
        return h_obs, ring_g

    def _h_obs(self, prob: LegProblem, xw: np.ndarray, yw: np.ndarray) -> np.ndarray:
        """The height (K,) above which ground under the samples is an obstacle: the reference surface (lift-off to
        touchdown height along the swing's progress) plus obstacle_step_m."""
        K = len(xw)
        x0, y0, z0 = prob.p_start.tolist()
        x1, y1, z1 = prob.p_target.tolist()
        dx, dy = x1 - x0, y1 - y0
        dd = dx * dx + dy * dy
        if dd > 1e-12:
            u = (xw - x0) * dx
            u += (yw - y0) * dy
            u /= dd
            prog = np.minimum(np.maximum(u, 0.0, out=u), 1.0, out=u)  # np.clip, without its dispatch cost
        else:
            prog = np.linspace(0.0, 1.0, K)
        h_obs = prog * (z1 - z0)
        h_obs += z0  # the reference surface ...
        h_obs += self.params.obstacle_step_m  # ... and the step above it that makes ground an obstacle
        return h_obs

    def _at_endpoints(
        self,
        prob: LegProblem,
        xw: np.ndarray,
        yw: np.ndarray,
        g: np.ndarray | None,
        ring_g: np.ndarray | None,
    ) -> np.ndarray | None:
        """The ground (K,) with the samples within SwingParams.endpoint_zone_m of the lift-off or the touchdown point
        no higher than that point; their ring probes (ring_g, in place) see no edge (either may be None: not
        asked)."""
        zone = float(self.params.endpoint_zone_m or 0.0)
        lift = prob.p_start[:2] if prob.xy_liftoff is None else prob.xy_liftoff
        for x, y, z in (
            (float(lift[0]), float(lift[1]), prob.z_ref),
            (float(prob.p_target[0]), float(prob.p_target[1]), float(prob.p_target[2])),
        ):
            dx = xw - x
            dy = yw - y
            near = dx * dx + dy * dy <= zone * zone
            if True in near.tolist():  # near.any(), without its dispatch cost (a tenth of the time)
                if g is not None:
                    g = np.where(near, np.minimum(g, z), g)
                if ring_g is not None:
                    ring_g[near] = -np.inf
        return g

    # ---- the tiers ----------------------------------------------------------------------------------------
    def analyze(
        self,
        prob: LegProblem,
        hp: HPath,
        u_total: float,
        simple: tuple[bool, float, bool] | None = None,
    ) -> Verdict:
        """Returns the tier of hp flown with the most aggressive vertical policy.

        The checks run in the order that decides the tier soonest: the other legs and the reach first (a foot hitting
        another leg, or a path that cannot reach, is ranked without the terrain), then the terrain, then the knees
        (not computed where the terrain collision decides the tier). Once a candidate of this problem collided with
        the terrain, the next ones look up the ground under their samples first and the ring probes only when they
        do not collide (two smaller lookups instead of one: cheaper for a collision, dearer otherwise). Only a
        verdict in Success, whose vertical checks read them, needs every field.

        simple: what the simple analysis found already, (limits_ok, miss_distance, reaches) of hp."""
        pr = self.params
        c = prob.ctx
        if simple is None:
            simple = (limits_ok(hp, c), miss_distance(hp, c), reaches(hp, c, pr))
        limits, miss, reach = simple
        if not limits:
            return Verdict(Tier.VIOLATES_CONSTRAINTS, (0.0,), u_total, miss)
        xw, yw = self.world_xy(prob, hp)
        zs = prob.zs_aggressive
        assert zs is not None, "analyze: a problem set up without the aggressive policy's samples"
        near_others = self._near_others(prob, xw, yw)
        gentlest_foot_sev = None
        if near_others:
            # the aggressive and the gentlest policies' feet against the other legs in one pass (the gentlest's
            # is what its vertical check needs, and the next lines when the aggressive one intrudes)
            (foot_sev, blame, near), (sev_low, blame_low, near_low) = self._foot_self_pair(
                near_others, xw, yw, zs, self.gentlest(prob)[1]
            )
            gentlest_foot_sev = sev_low  # vertical_ok of the gentlest policy reuses it
            if foot_sev > 0.0:
                # Higher is not always safer near another leg (its shin slants up and back): a vertical policy
                # exists that avoids the leg when the gentlest one does.
                near |= near_low
                if sev_low < foot_sev:
                    foot_sev, blame = sev_low, blame_low
        else:
            foot_sev, blame, near = 0.0, None, None
        bucket = pr.severity_bucket_m
        if foot_sev > 0.0 or not reach:
            v = Verdict(
                Tier.SELF_COLLISION, (math.floor(foot_sev / bucket), miss), u_total, miss, blame, xw, yw
            )
            if foot_sev <= 0.0:
                hyst = pr.miss_hysteresis_m if hp.name == prob.previous_policy else 0.0
                v.tier, v.key, v.blame = Tier.XY_CANT_REACH, (miss - hyst,), None
            v.near_others, v.foot_self_sev, v.gentlest_foot_sev = near_others, foot_sev, gentlest_foot_sev
            return v
        ring_g: np.ndarray | None
        if prob.flat_height is None:
            if prob.terrain_hit:
                g = self._ground_under(prob, xw, yw)
                pen = -float(_min(zs - g))  # terrain_scores's penetration
                if pen > pr.penetration_tol_m:
                    v = Verdict(
                        Tier.TERRAIN_COLLISION, (pen / bucket + u_total,), u_total, miss, None, xw, yw, g
                    )
                    v.near_others, v.foot_self_sev, v.gentlest_foot_sev = (
                        near_others,
                        foot_sev,
                        gentlest_foot_sev,
                    )
                    return v
                h_obs, ring_g = self._rings(prob, xw, yw)
            else:
                g, h_obs, ring_g = self._terrain_and_rings(prob, xw, yw)
            obstacle = g > h_obs
            any_obstacle = True in obstacle.tolist()  # obstacle.any()
        else:  # flat ground is never an obstacle
            g, _ = self._terrain(prob, xw, yw)
            obstacle, ring_g, any_obstacle = self._no_obstacle(len(xw)), None, False
        v = Verdict(Tier.SUCCESS, (u_total,), u_total, miss, None, xw, yw, g, obstacle, ring_g, any_obstacle)
        v.flat_height = prob.flat_height
        v.near_others, v.foot_self_sev, v.gentlest_foot_sev = near_others, foot_sev, gentlest_foot_sev
        pen, scrape, h_margin = self.terrain_scores(v, zs)
        if pen > pr.penetration_tol_m:
            # the tier is decided above the knee tiers whatever the knees do: they are not computed (the knee
            # fields stay empty)
            prob.terrain_hit = True
            v.tier, v.key = Tier.TERRAIN_COLLISION, (pen / bucket + u_total,)
            return v
        v.knee_idx, v.knee_terrain = self._knee_samples(prob, g, near)
        knee_terrain, knee_self, knee_blame = self._knees(prob, near_others, v, zs)
        v.knee_sev = (knee_terrain, knee_self)
        if knee_self > 0.0:
            v.tier, v.key, v.blame = (
                Tier.KNEE_SELF_COLLISION,
                (math.floor(knee_self / bucket), miss),
                knee_blame,
            )
        elif knee_terrain > 0.0:
            v.tier, v.key = Tier.KNEE_TERRAIN_COLLISION, (math.floor(knee_terrain / bucket), u_total)
        elif scrape or h_margin < pr.cliff_margin_m:
            v.tier, v.key = Tier.CLIFF_SCRAPING, (-h_margin, u_total)
        elif not prob.z_ok:
            v.tier, v.key = Tier.XY_SUCCESS_Z_IMPOSSIBLE, (u_total,)
        return v

    def terrain_scores(self, v: Verdict, zs: np.ndarray) -> tuple[float, bool, float]:
        """Returns (penetration depth m, vertical margin short over an obstacle, horizontal margin m)."""
        pr = self.params
        h = v.flat_height
        if h is not None and len(zs):
            # flat ground (no obstacle, no rings): min(zs − h) is min(zs) − h, subtracting a constant keeps the
            # order, rounding included
            return -(float(_min(zs)) - h), False, math.inf
        clear = zs - v.g
        pen = -float(_min(clear)) if len(clear) else 0.0
        # the .any() of small boolean arrays as `True in` their lists: the same answer, a tenth of the time
        scrape = v.any_obstacle and True in (v.obstacle & (clear < pr.clearance_margin_m)).tolist()
        if scrape:
            return pen, True, 0.0
        h_margin = math.inf
        if v.ring_g is not None:
            hit = v.ring_g.T > zs - pr.clearance_margin_m  # (R,K)
            for radius, ring in zip(self._ring_radii_f, hit.tolist(), strict=True):
                if True in ring:  # the innermost ring with a hit
                    h_margin = radius
                    break
        return pen, scrape, h_margin

    def clearance_need(self, v: Verdict) -> float:
        """The height (m) the foot must exceed somewhere along v's path for any vertical policy to pass
        terrain_scores: a policy whose peak stays below it scrapes an obstacle or its cliff margin is short
        (-inf when nothing on the way asks for height)."""
        need = -math.inf
        if v.any_obstacle:
            need = float(_max(v.g[v.obstacle]))
        if v.ring_g is not None and self._n_cliff_rings:
            need = max(need, float(_max(v.ring_g[:, : self._n_cliff_rings], axis=None)))
        return need + self.params.clearance_margin_m

    def gentlest(self, prob: LegProblem) -> tuple[Poly1D, np.ndarray]:
        """The gentlest vertical policy's trajectory for this leg and its samples (computed once per leg)."""
        if prob.z_gentlest is None or prob.zs_gentlest is None:
            z0, vz0, z1 = prob.z_v_z1
            prob.z_gentlest, prob.z_gentlest_ok = vertical(
                self.family[0], prob.ctx.t0, z0, vz0, z1, prob.ctx.t_end, prob.z_ceiling, prob.z_ref
            )
            prob.zs_gentlest = prob.z_gentlest.sample_many(prob.ts)
        return prob.z_gentlest, prob.zs_gentlest

    def _near_others(self, prob: LegProblem, xw: np.ndarray, yw: np.ndarray) -> list[OtherLeg]:
        """Other legs whose lower leg comes within the knee-check radius of the path's x/y extent."""
        if not prob.others:
            return []
        r = max(self.params.knee_check_radius_m, self.params.keepout_radius_m)
        xl, yl = xw.tolist(), yw.tolist()  # finite sample positions: min and max of the lists, as NumPy's
        x0, x1, y0, y1 = min(xl) - r, max(xl) + r, min(yl) - r, max(yl) + r
        return [
            o
            for o in prob.others
            if o.xy_box[0] <= x1 and o.xy_box[1] >= x0 and o.xy_box[2] <= y1 and o.xy_box[3] >= y0
        ]

    def _foot_self(
        self, others: list[OtherLeg], xw: np.ndarray, yw: np.ndarray, zs: np.ndarray
    ) -> tuple[float, int | None, np.ndarray]:
        """Worst foot-to-other-leg intrusion (m), the leg intruded on, and samples near any other leg."""
        near = np.zeros(len(xw), dtype=bool)
        if not others:
            return 0.0, None, near
        p = np.empty((len(xw), 3))
        p[:, 0] = xw
        p[:, 1] = yw
        np.add(zs, self.r_foot, out=p[:, 2])
        worst, blame = 0.0, None
        for o in others:
            d, _ = _point_segment(p, o.foot_center, o.shank)
            sev = float(self.params.keepout_radius_m - d.min())
            if sev > worst:
                worst, blame = sev, o.leg
            near |= d < self.params.knee_check_radius_m
        return worst, blame, near

    def _foot_self_pair(
        self, others: list[OtherLeg], xw: np.ndarray, yw: np.ndarray, zs_a: np.ndarray, zs_b: np.ndarray
    ) -> tuple[tuple[float, int | None, np.ndarray], tuple[float, int | None, np.ndarray]]:
        """_foot_self for two vertical trajectories zs_a, zs_b along one path, in one pass over the other legs
        (the same arithmetic as _point_segment, on (2,K) samples)."""
        K = len(xw)
        p = np.empty((2, K, 3))
        p[:, :, 0] = xw
        p[:, :, 1] = yw
        np.add(zs_a, self.r_foot, out=p[0, :, 2])
        np.add(zs_b, self.r_foot, out=p[1, :, 2])
        worst: list[float] = [0.0, 0.0]
        blame: list[int | None] = [None, None]
        near = np.zeros((2, K), dtype=bool)
        r_keep, r_knee = self.params.keepout_radius_m, self.params.knee_check_radius_m
        for o in others:
            a, sv = o.foot_center, o.shank
            ss = float(sv @ sv)
            if ss > 1e-12:
                u = np.minimum(np.maximum(((p - a) @ sv) / ss, 0.0), 1.0)
            else:
                u = np.zeros((2, K))
            e = p - (a + u[..., None] * sv)
            d = np.sqrt(np.add.reduce(e * e, axis=2))  # (2,K)
            sev_a, sev_b = (r_keep - d.min(axis=1)).tolist()
            if sev_a > worst[0]:
                worst[0], blame[0] = sev_a, o.leg
            if sev_b > worst[1]:
                worst[1], blame[1] = sev_b, o.leg
            near |= d < r_knee
        return (worst[0], blame[0], near[0]), (worst[1], blame[1], near[1])

    def _knee_samples(
        self, prob: LegProblem, g: np.ndarray, near: np.ndarray | None
    ) -> tuple[np.ndarray, bool]:
        """Sample indices at which to compute knees, and whether knees can reach the terrain at all (near: the
        samples near another leg, None: none is).

        Knees lie within knee_reach of the hips: when the hips stand higher than that above every ground height
        probed (under the path, and on a grid up to knee_reach fore and aft of the hips), no knee touches terrain;
        knees are then computed only where the foot comes near another leg.
        """
        pr = self.params
        if prob.g_knee_max is None:
            if prob.flat_height is not None:
                prob.g_knee_max = prob.flat_height
            else:
                px, py = self.knee_grid(prob.leg, prob.hips, prob.cos_yaw, prob.sin_yaw)
                prob.g_knee_max = float(_max(prob.ground(px, py)))
        # on flat ground g is all flat_height (= g_knee_max)
        g_max = prob.g_knee_max if prob.flat_height is not None else max(prob.g_knee_max, float(_max(g)))
        terrain = prob.hip_z_min - self.knee_reach - g_max < pr.knee_radius_m
        idx = self._knee_idx(len(g))
        if not terrain:
            idx = _NO_SAMPLES if near is None else idx[near[idx]]
        return idx, terrain

    def knee_grid(self, leg: int, hips: np.ndarray, c: float, sn: float) -> tuple[np.ndarray, np.ndarray]:
        """World x and y of the ground probed for the knees: a grid fore and aft of the hips (3,3) at the swing's
        start, middle and end, in line with the hip and with the foot (abduction offset); heading cos c, sin sn."""
        fore, side = self._knee_grid_flat[leg]  # the grid's (fore, side) pairs, flat
        ox = fore * c
        ox -= side * sn
        oy = fore * sn
        oy += side * c
        return (hips[:, 0:1] + ox).ravel(), (hips[:, 1:2] + oy).ravel()

    def _flat(self, K: int, height: float) -> np.ndarray:
        """np.full(K, height), cached per K and height (read-only: the verdicts only read their ground)."""
        key = (K, height)
        a = self._flat_cache.get(key)
        if a is None:
            if len(self._flat_cache) > 64:
                self._flat_cache.clear()
            a = self._flat_cache[key] = np.full(K, height)
            a.flags.writeable = False
        return a

    def _no_obstacle(self, K: int) -> np.ndarray:
        """K samples none of which is over an obstacle (cached per K; read-only)."""
        a = self._no_obstacle_cache.get(K)
        if a is None:
            a = self._no_obstacle_cache[K] = np.zeros(K, dtype=bool)
            a.flags.writeable = False
        return a

    def _knee_idx(self, K: int) -> np.ndarray:
        """The knee_samples interior sample indices of K samples, evenly spread (cached per K; read-only)."""
        idx = self._knee_idx_cache.get(K)
        if idx is None:
            idx = np.unique(np.linspace(1, K - 2, self.params.knee_samples).round().astype(int))
            idx.flags.writeable = False
            self._knee_idx_cache[K] = idx
        return idx

    def _knees(
        self,
        prob: LegProblem,
        others: list[OtherLeg],
        v: Verdict,
        zs: np.ndarray,
    ) -> tuple[float, float, int | None]:
        """Knee-terrain and knee-to-other-leg intrusions (m) at v's knee samples, through the leg IK."""
        pr = self.params
        if len(v.knee_idx) == 0:
            return 0.0, 0.0, None
        idx = v.knee_idx
        n = len(idx)
        if n <= _FEW_KNEES:
            # a few knees: Python floats throughout (arrays only for a lookup of mapped ground)
            rows, kept_l = self._knee_rows(prob, v, zs)
            if not rows:
                return 0.0, 0.0, None
            kt = 0.0
            if v.knee_terrain:
                if prob.flat_height is not None:
                    h = prob.flat_height
                    clear = min([r[2] - h for r in rows])  # (kn[:, 2] - gk).min(), the same differences
                else:
                    kn_a = np.array(rows)
                    gk = np.asarray(prob.ground(kn_a[:, 0], kn_a[:, 1]), dtype=float)
                    clear = float((kn_a[:, 2] - gk).min())
                kt = max(0.0, float(pr.knee_radius_m - clear))
            ks, blame = 0.0, None
            for o in others:
                fcs = o.foot_center.tolist()
                d_min = min(
                    _point_segment_f(r, fcs[0] if len(fcs) == 1 else fcs[k], o.shank_f)
                    for r, k in zip(rows, kept_l, strict=True)
                )
                sev = pr.knee_keepout_m - d_min
                if sev > ks:
                    ks, blame = sev, o.leg
            return kt, ks, blame
        kn, kept_many = self._knees_many(prob, v, zs)
        if kept_many is None:
            return 0.0, 0.0, None
        kept = kept_many
        kt = 0.0
        if v.knee_terrain:
            gk = (
                np.full(len(kn), prob.flat_height)
                if prob.flat_height is not None
                else np.asarray(prob.ground(kn[:, 0], kn[:, 1]), dtype=float)
            )
            kt = max(0.0, float(pr.knee_radius_m - (kn[:, 2] - gk).min()))
        ks, blame = 0.0, None
        for o in others:
            fc = o.foot_center if len(o.foot_center) == 1 else o.foot_center[kept]
            d, _ = _point_segment(kn, fc, o.shank)
            sev = float(pr.knee_keepout_m - d.min())
            if sev > ks:
                ks, blame = sev, o.leg
        return kt, ks, blame

    def _knees_few(
        self, prob: LegProblem, v: Verdict, zs: np.ndarray
    ) -> tuple[np.ndarray | None, np.ndarray]:
        """World knees (m, n×3) at a few of v's knee samples (_knee_rows as arrays), and the samples they are at
        (out of reach ones left out)."""
        rows, kept = self._knee_rows(prob, v, zs)
        if not rows:
            return None, v.knee_idx
        return np.array(rows), np.array(kept, dtype=int)

    def _knee_rows(self, prob: LegProblem, v: Verdict, zs: np.ndarray) -> tuple[list[list[float]], list[int]]:
        """World knees (m, rows of 3 floats) at a few of v's knee samples, one leg IK each in Python floats (~3 µs a
        row; the vectorized IK costs ~35 µs, for one row as for twenty); and the samples they are at (out of reach
        ones left out)."""
        robot, leg, rf = self.robot, prob.leg, self.r_foot
        rows: list[list[float]] = []
        kept: list[int] = []
        poses = prob.pose_floats
        xw, yw, zl = v.xw.tolist(), v.yw.tolist(), zs.tolist()
        for k in v.knee_idx.tolist():
            pose = poses.get(k)
            if pose is None:
                pose = poses[k] = _pose_floats(prob.body, float(prob.ts[k]))
            px, py, pz, r00, r01, r02, r10, r11, r12, r20, r21, r22 = pose
            dx, dy, dz = xw[k] - px, yw[k] - py, zl[k] + rf - pz
            knee_b = robot.knee_of_foot(
                leg,
                r00 * dx + r10 * dy + r20 * dz,
                r01 * dx + r11 * dy + r21 * dz,
                r02 * dx + r12 * dy + r22 * dz,
            )
            if knee_b is None:
                continue  # out of reach
            bx, by, bz = knee_b
            rows.append(
                [
                    px + r00 * bx + r01 * by + r02 * bz,
                    py + r10 * bx + r11 * by + r12 * bz,
                    pz + r20 * bx + r21 * by + r22 * bz,
                ]
            )
            kept.append(k)
        return rows, kept

    def _knees_many(
        self, prob: LegProblem, v: Verdict, zs: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray | None]:
        """World knees (m, n×3) at v's knee samples through one vectorized leg IK, and the samples they are at
        (None: none in reach)."""
        idx = v.knee_idx
        n = len(idx)
        foot_c = np.empty((n, 3))  # foot centers at the knee samples, world
        foot_c[:, 0] = v.xw[idx]
        foot_c[:, 1] = v.yw[idx]
        np.add(zs[idx], self.r_foot, out=foot_c[:, 2])
        p_ws, Rs = self._poses(prob, idx)
        # body-frame feet of all samples at once: Rᵀ (foot − p) per sample
        p_body_foot = np.einsum("nji,nj->ni", Rs, foot_c - p_ws)
        # one vectorized IK over the samples (rows out of reach are skipped, as ik_leg's ReachError was)
        q, ok = self.robot.ik_leg_many(prob.leg, p_body_foot)
        if not ok.any():
            return p_ws, None
        knee_b = self.robot.knee_body_many(prob.leg, q)
        if ok.all():
            return p_ws + np.einsum("nij,nj->ni", Rs, knee_b), idx
        return p_ws[ok] + np.einsum("nij,nj->ni", Rs[ok], knee_b[ok]), idx[ok]

    def _poses(self, prob: LegProblem, idx: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The body's predicted positions (n,3) and orientations (n,3,3) at samples idx, stacked (cached per
        problem and index set: the knee checks of every candidate path use the same samples)."""
        key = idx.tobytes()
        out = prob.pose_stacks.get(key)
        if out is None:
            poses = prob.poses
            body = prob.body
            pose_list = []
            for k in idx.tolist():
                pose = poses.get(k)
                if pose is None:
                    pose = poses[k] = body.pose_at(float(prob.ts[k]))
                pose_list.append(pose)
            out = prob.pose_stacks[key] = (
                np.array([pw for pw, _ in pose_list]),
                np.array([R for _, R in pose_list]),
            )
        return out

    # ---- vertical policy check ----------------------------------------------------------------------------
    def vertical_ok(self, prob: LegProblem, v: Verdict, zs: np.ndarray) -> bool:
        """True when a vertical trajectory sampled at zs keeps the required margins along the chosen path (and
        its knees and foot come no closer to terrain and other legs than with the most aggressive policy)."""
        pen, scrape, h_margin = self.terrain_scores(v, zs)
        if pen > self.params.penetration_tol_m or scrape or h_margin < self.params.cliff_margin_m:
            return False
        if v.near_others:
            if zs is prob.zs_gentlest and v.gentlest_foot_sev is not None:
                sev = v.gentlest_foot_sev
            else:
                sev, _, _ = self._foot_self(v.near_others, v.xw, v.yw, zs)
            if sev > v.foot_self_sev + 1e-9:
                return False
        if len(v.knee_idx):
            kt, ks, _ = self._knees(prob, v.near_others, v, zs)
            if kt > v.knee_sev[0] + 1e-9 or ks > v.knee_sev[1] + 1e-9:
                return False
        return True
