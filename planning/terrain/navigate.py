"""Terrain-aware walking: perception, body path, path following, step-QP footholds and body height, in the loop.

``TerrainNavigator`` plugs into a ``WalkController`` through its terrain hooks and adds two stages:

- ``perception`` (~10 Hz): a depth scan of the live MuJoCo data → voxels → maps, written to ``controller.maps``
  (the step planner screens no-step cells with them, the swing planner takes its ground from them); with
  ``use_sensor=False`` the scene's ground-truth maps (perfect perception) are used instead, re-centered on the body;
- ``body_path`` (~2 Hz, and at once when the current path's footprint sweep hits the body-obstacle map): a body path
  from the body to the goal, then the gait cadence overlaid on it, whose speed caps the walking speed.

and sets two hooks:

- ``command_source``: pure pursuit of the body path (a point ``lookahead_m`` ahead), the speed of the chosen cadence,
  slowed where the step-obstacle map is dense around the body and near the goal, yaw turned toward the path's;
- ``foothold_filter``: when any planned foothold lies on or near a no-step cell, the step QP refines the selected
  step path's footholds (nominal = the capture-point selection), and the swing targets follow; otherwise the
  selection passes unchanged. It runs at the step-plan rate (100 Hz).

The body height target is lowered where the clearance map (the free height under an overhang) ahead is low.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import mujoco
import numpy as np
from numpy.typing import NDArray
from scipy import ndimage

from planning.sim.loop import Stage
from planning.sim.world import RobotState
from planning.steps import SteeringCommand
from planning.steps.gait import Gait, get_gait
from planning.steps.select import Selection
from planning.steps.state import StepPath, rotate_yaw
from planning.terrain.bodypath import (
    BodyPath,
    BodyPathParams,
    plan_body_path,
    sweep_clearance,
    sweep_points_clearance,
)
from planning.terrain.cadence import CadenceParams, CadenceScore, choose_cadence
from planning.terrain.maps import TerrainMaps, _gradient, maps_from_scene, signed_distance
from planning.terrain.overlays import map_overlays, plan_overlays
from planning.terrain.perception import Perception, PerceptionParams
from planning.terrain.scenes import TerrainScene
from planning.terrain.stepqp import StepPlan, StepQP, StepQPParams, StepRequest
from planning.terrain.treads import (
    TreadLine,
    TreadMargins,
    choose_tread,
    clear_of_nosing,
    risers_along,
    shin_ground,
    tread_line,
)


def _stairs_swing() -> dict[str, Any]:
    return {
        "a_max_z_mps2": 40.0,
        "terrain_apex_m": None,
        "apex_free_over_obstacles": False,
        "cliff_margin_m": 0.03,
        "cliff_rings_m": (0.01, 0.02, 0.03),
        "rise_first_margin_m": 0.05,
        "rise_first_gap_m": 0.08,
        "rise_first_anchored": True,
        "rise_first_within_reach": True,
    }


@dataclass(frozen=True)
class StairsMode:
    """What changes on stairs: a run of at least min_risers risers, each within max_tread_m of the last and all
    rising (or all dropping), along both feet's lines in the climb window (see NavigatorParams.climb_*). The mode
    holds until no riser is left in the window (the landing between flights stays in it).

    Footholds are chosen tread by tread (treads: the margins, see planning.terrain.treads; None: the step QP on
    the no-step map instead): each swing lands on its own tread or the next, chosen at liftoff, away from the
    riser ahead and the nosing behind. The body is paced by its feet: the climb speed (one tread per gait cycle)
    is scaled by 1 + pace_gain_per_s × (how far the feet, with the swings' chosen touchdowns, are ahead of the
    body, less how far the most trailing foot is behind its hip beyond pace_lag_m) / climb speed, within
    pace_range: a foot that stayed on its tread is waited for instead of left to trail at full stretch. The swing
    planner sees the ground with every nosing carried shin_reach_m forward (see treads.shin_ground): a foot stepping
    down stays high until its trailing shin clears the nosing.

    Stairs want the opposite of clutter in a few places, measured on both: a swing over a riser rises at 40 m/s²,
    not clutter's 60 (a foot thrown up fast overshoots and lands late on the next tread), with no extra apex over
    obstacles seen late and no apex cap from the ground on the way (the rise-first hold already clears the nosing),
    a 3 cm cliff margin (a 30 cm tread has little room for 5); a rise-first wait 5 cm over the nosing, 8 cm short of
    the riser, fixed from the lift-off place and lowered to what the leg reaches (measured: the foot was carried
    into the riser while it waited, or did not wait at all when its hip was low); the shin keep-out of a foot under
    its hip (shin_radius_m, shin_foot_ahead_m, shin_min_rise_m as in NavigatorParams), and no swing-target hold
    against foothold flips.

    enabled: False keeps the default behaviour everywhere; ahead_m: how far ahead of the body the flight is looked
    for (m); gait: the gait on stairs (None: NavigatorParams.climb_gait; "stairs" is a trot with 0.4 s swings: the
    0.3 s of "climb" left too little time to rise over a riser, longer or four-foot phases rolled the body); swing:
    SwingParams fields set in the mode (the vertical family keeps its absolute accelerations);
    replan_height_from_plan_m: HandlerParams.replan_height_from_plan_m in the mode: a swing's height is replanned
    from its last plan while the foot is within this of it, so the leg keeps tracking one trajectory (replanned
    from the measured foot, a foot rising over a riser went on rising 12 cm past its planned top and the next pair
    lifted off before it landed; 15 of the 18 stairs variants crossed, 17 with it; the stones crawl, tuned against
    the measured replanning, crossed 2–3 of 6 with it against 5, so it stays a stairs rule); center_m: climbing,
    the path point the body steers to is moved across the heading to the middle of the span free of body
    obstacles through it (the railings), looked for up to center_m either side (0: off; see corridor_middle): a
    path planned from where the body is runs along the stairs at whatever offset a sway or a detour left it, and
    three climbs rolled over toward the railing they had drifted to (30 of 34 variants crossed, 32 with it; going
    down too, 32 as well, but the default walk with the sensor fell going down).

    Going down (no riser left ahead of the hind hips that rises, one that drops): descent_gait, the trot with
    0.3 s swings (the 0.4 s diagonal phases of "stairs" let the body roll or drift sideways off its line, one
    foot's clearance at a time; going down no swing waits to rise over a riser); the body pitch target is the
    slope from the hind feet to the front feet where they stand (pitch_from_feet), not of the ground sampled
    around the body, which over the flight's top edge flipped between 0° and 7° from one scan to the next while the
    front feet already stood two treads down (the body pitched 10° where the feet asked for 25°: the hind hips sat
    low); and each foot stepping down lands where its shin clears the nosing it stepped over by shin_clear_m
    (see treads.clear_of_nosing, with the hip where it will be at touchdown): the knees point back, so the shin
    slants back over the nosing from the foot, the more so the nearer the foot lands below its hip. Measured on
    the first ten stairs variants of `footfall bench --only stairs_variants`: 5 crossed without these, 9 with them
    (and 6 of the 8 further offsets, every descent among them). shin_clear_m 0.10 m, not 0.07: after touchdown
    the body goes on dropping and the knee folds back, and at 0.07 a front shin met the last nosing on 3 of 34
    variants (goal offsets −8 to +8 cm every 1 cm, with the sensor and on ground-truth maps): 28 of them crossed,
    30 at 0.10.
    """

    enabled: bool = True
    gait: str | None = "stairs"
    descent_gait: str | None = "climb"
    pitch_from_feet: bool = True
    shin_clear_m: float = 0.10
    ahead_m: float = 1.6
    min_risers: int = 2
    max_tread_m: float = 0.5
    shin_radius_m: float = 0.04
    shin_foot_ahead_m: float = 0.0
    shin_min_rise_m: float = 0.03
    hold_swing_targets: bool = False
    swing: dict[str, Any] = field(default_factory=_stairs_swing)
    treads: TreadMargins | None = field(default_factory=TreadMargins)
    pace_gain_per_s: float = 1.0
    pace_lag_m: float = 0.18
    pace_range: tuple[float, float] = (0.0, 1.5)
    shin_reach_m: float = 0.10
    replan_height_from_plan_m: float = 0.03
    center_m: float = 0.8


def _stones_qp() -> StepQPParams:
    return StepQPParams(snap_search_m=0.5, snap_clearance_m=0.06, snap_middle=True, snap_spread_m=0.04)


def _stones_maps() -> dict[str, Any]:
    return {"max_step_height_m": 0.5, "body_above_ground_m": 0.05, "fill_low_radius_m": 0.15}


@dataclass(frozen=True)
class StonesMode:
    """What changes over stepping stones: the mode is on while either foot line, from behind_m behind to ahead_m
    ahead of the body, dips more than drop_m below the ground the feet stand on and comes back up to within
    return_m of it further on (a pit or gaps between steppable patches; descending stairs never come back up, a
    box is no dip), and off once no such dip is left.

    In the mode the controller walks in the gait `gait` (a duty above 0.75 keeps four feet down between swings, so
    a foot landing late after a long step across a gap never leaves the body on two) at speed_mps; the step QP
    snaps footholds on a gap along the heading onto the nearer stone (step_qp, see StepQPParams.snap_search_m; on
    near ties a front foot takes the stone ahead and a hind foot the one behind, snap_spread_m 4 cm: with it scene
    seeds 0-2 cross with and without the sensor, without it seed 2 fell);
    and a foothold the QP moved is kept once its touchdown is less than freeze_touchdown_s away (no late re-aim
    across a gap). The step obstacles are grown by foot_margin_m and the drop keep-out reaches drop_reach_m (the
    maps' own edge band already keeps the foot's radius off a stone's edge: a 30 cm stone keeps little room with
    more). A snapped foothold with a step SDF of at least pin_min_sdf_m is taken as it is, not the QP's answer
    (its other terms pull a foot toward a stone's edge; None: the QP's). The maps are built with the MapParams
    fields in `maps` changed (a stone stands high above the pit floor next to it: no step obstacle for that, and its
    top edge seen from the pit is no body obstacle, and the unseen shadow behind its far edge reads as pit, not as
    more stone), and the stairs mode stays off (a gap half seen looks like a riser). enabled: False keeps the default behaviour everywhere.
    """

    enabled: bool = True
    drop_m: float = 0.15
    return_m: float = 0.08
    behind_m: float = 0.5
    ahead_m: float = 1.0
    gait: str = "crawl"
    speed_mps: float = 0.25
    freeze_touchdown_s: float = 0.12
    foot_margin_m: float = 0.0
    drop_reach_m: float = 0.0
    pin_min_sdf_m: float | None = 0.03
    step_qp: StepQPParams = field(default_factory=_stones_qp)
    maps: dict[str, Any] = field(default_factory=_stones_maps)


@dataclass(frozen=True)
class NavigatorParams:
    """Terrain-aware walking (lengths m, speeds m/s, rates Hz).

    use_sensor: maps from the depth sensor (True) or the scene's ground truth (False); truth_half_extent_m,
    truth_recenter_m: size of the ground-truth map around the body and the body travel that rebuilds it;
    perception_rate_hz, path_rate_hz: stage rates; lookahead_m: pure-pursuit lookahead on the body path;
    yaw_gain: 1/s, path yaw error → yaw rate; max_yaw_rate_rps: rad/s; goal_gain: 1/s, goal distance → speed;
    goal_tolerance_m: stop within this of the goal; max_speed_mps, min_speed_mps: speed range along the path;
    dense_radius_m: disk ahead of the body whose no-step share slows the walk; dense_full: share at which the speed
    reaches min_speed_mps; qp_trigger_m: the step QP runs when a planned foothold's step SDF is below this;
    qp_min_time_s: a touchdown sooner than this is left as it is; standing_height_m: body height target on open
    ground (None: the robot's); min_height_m: lowest body height target; body_top_m: body top above the body
    center (m, with the hips); head_margin_m: wanted gap between the body top and an overhang; crouch_ahead_m:
    how far ahead (and behind) along the heading the clearance is looked up; crouch_side_m: and to either side
    (remembered overhangs); memory_cell_m: cell of the overhang memory; shin_radius_m, shin_reach_m, shin_min_rise_m: the
    stance shin's keep-out added to the step obstacles (see shin_keepout; the slope comes from the robot's knee
    with the foot shin_foot_ahead_m ahead of its hip at the standing height: a foot landing ahead of its hip has a
    flatter shin than at the nominal stance); foot_margin_m: step obstacles grown by this; riser_margin_m,
    riser_height_m: cells with ground higher by more than riser_height_m within riser_margin_m are no-step too (the
    foot sphere would scrape the side of a box or riser; a drop needs no such margin).
    riser_reach_m, riser_rise_m: the riser keep-out in front of a foothold (see riser_keepout; 0 reach: none);
    drop_reach_m: the same for a drop ahead (the nosing going down).
    max_pitch_rad, max_pitch_rate_rps: limits of the body pitch target along the ground slope (rad, rad/s);
    slow_gait: gait the controller switches to where the step-obstacle map ahead is dense (the no-step share of
    the dense_radius_m disk ahead above slow_gait_on), and back to its own gait once the share is below
    slow_gait_off (one foot at a time lands more precisely and the others hold the body meanwhile); stay_slow: once
    in the slow gait, stay in it (measured on clutter: the switch back to the trot can leave three feet in the air
    at once, and the walk is as fast as the navigator's max_speed_mps anyway); slow_gait_speed_mps: speed cap in the slow
    gait (its steps are one cycle long: 0.5 m steps in 0.25 s swings over boxes trip and land late); hold_jump_m, hold_radius_m,
    hold_min_sdf_m: a swinging foot's target does not jump (by more than hold_jump_m from one step-plan tick to the
    next) while its held target stays steppable (step SDF ≥ hold_min_sdf_m) and within hold_radius_m of the new
    selection's (the foothold choice may flip between the sides of an obstacle; a foot chasing the flips lands late,
    on an edge, or trips over what its swing was not planned to clear).
    climb_gait: gait used, before any other, while the ground along the feet's lines from climb_behind_m behind to
    climb_ahead_m ahead of the body has a step (a rise or a drop above climb_rise_m within two cells): stairs,
    a curb (long swings give the foot time to rise above a riser before moving on; None: never); the speed there
    is one riser pitch per gait cycle (one tread per step), within min_speed_mps and the gait's top speed.
    stairs: the stairs mode (see StairsMode); stones: the stepping-stones mode (see StonesMode).
    keep_heading_m: walking to a goal, where the steering filter's clipping of the path's velocity component by
    component (a walk's sideways limit is 0.19 m/s) would sweep the body's footprint within this of a body
    obstacle over the next stop_horizon_s, the velocity is scaled as a whole into the limits instead, keeping
    the path's direction (see direction_kept; 0: never; not in the stairs and stones modes, whose forward
    speed is paced by the treads and stones).
    stop_horizon_s, stop_margin_m: when steered, the commanded velocity slows so the body's footprint swept over
    the next stop_horizon_s keeps stop_margin_m from body obstacles (see _obstacle_stop; 0 s: never).
    late_descent_gain_per_s: set on the controller's swing planner (SwingParams): a late foot high above its
    touchdown (after a step down or a rise over a riser) descends faster, 1/s.
    lag_slow_m: off stairs, the speed scales down linearly from 1 to 0 as the stance foot farthest behind its hip
    (along the heading) trails it by the first to the second length (m): a foot whose step over a box failed, or
    that landed short, is waited for instead of left behind while the body walks off its support.
    hip_ground_min_m, hip_ground_max_m: the body height target follows the ground under the hips where it differs
    from the feet's by more than the first, by at most the second (see _ground_offset; 0: never).
    overlay_plan_s: the studio shows the step QP's footholds while its last solve is at most this old (s).
    """

    use_sensor: bool = True
    truth_half_extent_m: float = 2.5
    truth_recenter_m: float = 0.8
    perception_rate_hz: float = 10.0
    path_rate_hz: float = 2.0
    lookahead_m: float = 0.45
    yaw_gain: float = 1.2
    max_yaw_rate_rps: float = 0.5
    goal_gain: float = 0.8
    goal_tolerance_m: float = 0.06
    max_speed_mps: float = 0.5
    min_speed_mps: float = 0.2
    dense_radius_m: float = 0.6
    dense_full: float = 0.35
    qp_trigger_m: float = 0.06
    qp_min_time_s: float = 0.04
    standing_height_m: float | None = None
    min_height_m: float = 0.38
    body_top_m: float = 0.10
    head_margin_m: float = 0.04
    crouch_ahead_m: float = 0.7
    crouch_side_m: float = 0.15
    memory_cell_m: float = 0.05
    shin_radius_m: float = 0.0
    shin_reach_m: float = 0.27
    shin_foot_ahead_m: float = 0.15
    shin_min_rise_m: float = 0.02
    foot_margin_m: float = 0.03
    riser_reach_m: float = 0.10
    riser_rise_m: float = 0.08
    drop_reach_m: float = 0.05
    riser_margin_m: float = 0.07
    riser_height_m: float = 0.04
    max_pitch_rad: float = 0.45
    max_pitch_rate_rps: float = 0.6
    slow_gait: str = "walk"
    slow_gait_on: float = 0.15
    slow_gait_off: float = 0.05
    climb_gait: str | None = "climb"
    climb_rise_m: float = 0.08
    climb_behind_m: float = 0.8
    climb_ahead_m: float = 1.2
    climb_steps_per_tread: int = 1
    late_descent_gain_per_s: float = 5.0
    hip_ground_min_m: float = 0.04
    hip_ground_max_m: float = 0.15
    stay_slow: bool = True
    slow_gait_speed_mps: float = 0.3
    lag_slow_m: tuple[float, float] = (0.22, 0.36)
    stairs: StairsMode = field(default_factory=StairsMode)
    stones: StonesMode = field(default_factory=StonesMode)
    keep_heading_m: float = 0.3
    stop_horizon_s: float = 0.6
    stop_margin_m: float = 0.05
    hold_jump_m: float = 0.04
    hold_radius_m: float = 0.15
    hold_min_sdf_m: float = 0.01
    overlay_plan_s: float = 0.3
    perception: PerceptionParams = field(default_factory=PerceptionParams)
    path: BodyPathParams = field(default_factory=BodyPathParams)
    cadence: CadenceParams | None = None  # None: from the robot
    step_qp: StepQPParams = field(default_factory=StepQPParams)


def _p(values: list[float], q: float) -> float | None:
    return round(float(np.percentile(values, q)), 3) if values else None


@dataclass
class NavigatorStats:
    """Counters for the run report: replans of each kind, step-QP use and its timing (ms; whole replans and OSQP's
    own solves in them), the depth scans' sizes (points), time in the stairs mode and of it going down (s), time
    in the stones mode (s)."""

    scans: int = 0
    body_paths: int = 0
    invalid_paths: int = 0
    qp_solves: int = 0
    qp_used: int = 0
    qp_ms: list[float] = field(default_factory=list)
    qp_bare_ms: list[float] = field(default_factory=list)
    cloud_points: list[int] = field(default_factory=list)
    cadences: dict[str, int] = field(default_factory=dict)
    min_height_m: float = np.inf
    gait_switches: int = 0
    stairs_mode_s: float = 0.0
    stairs_descent_s: float = 0.0
    stones_mode_s: float = 0.0

    def summary(self) -> dict[str, Any]:
        return {
            "scans": self.scans,
            "body_paths": self.body_paths,
            "invalid_paths": self.invalid_paths,
            "step_qp_solves": self.qp_solves,
            "step_qp_used": self.qp_used,
            "step_qp_ms_p50": _p(self.qp_ms, 50),
            "step_qp_ms_p99": _p(self.qp_ms, 99),
            "step_qp_bare_solver_ms_p50": _p(self.qp_bare_ms, 50),
            "step_qp_bare_solver_ms_p99": _p(self.qp_bare_ms, 99),
            "cloud_points_p50": None if not self.cloud_points else int(np.median(self.cloud_points)),
            "cadences": dict(self.cadences),
            "gait_switches": self.gait_switches,
            "stairs_mode_s": round(self.stairs_mode_s, 2),
            "stairs_descent_s": round(self.stairs_descent_s, 2),
            "stones_mode_s": round(self.stones_mode_s, 2),
            "min_body_height_target_m": None
            if not np.isfinite(self.min_height_m)
            else round(self.min_height_m, 3),
        }


class TerrainNavigator:
    """Terrain-aware walking to a goal on a WalkController (see the module docstring). ``attach`` sets the hooks."""

    def __init__(
        self,
        controller: Any,
        model: mujoco.MjModel,
        data: mujoco.MjData,
        goal_xy: tuple[float, float] | None,
        scene: TerrainScene | None = None,
        params: NavigatorParams | None = None,
        body: str = "trunk",
    ) -> None:
        self.params = p = params or NavigatorParams()
        if goal_xy is not None and not np.all(np.isfinite(goal_xy)):
            raise ValueError(f"TerrainNavigator.goal_xy: must be finite, got {goal_xy}")
        if not p.use_sensor and scene is None:
            raise ValueError("TerrainNavigator: use_sensor=False needs the scene (ground-truth maps)")
        self.controller = controller
        self.robot = controller.robot
        self.data = data
        self.scene = scene
        # None: steered (the controller's velocity command, within the terrain's speed limits), no body path
        self.goal = None if goal_xy is None else np.asarray(goal_xy, dtype=np.float64).reshape(2)
        self.perception = Perception(model, body, p.perception) if p.use_sensor else None
        self.cadence_params = p.cadence or CadenceParams.from_robot(self.robot)
        self.qp = StepQP(p.step_qp)
        self.qp_stones = StepQP(p.stones.step_qp) if p.stones.enabled else self.qp
        self.stones_maps = dataclasses.replace(p.perception.maps, **p.stones.maps)
        self.standing_height = p.standing_height_m or float(self.robot.standing_height_m)
        self.p_body_hip_xy = np.asarray(self.robot.p_body_hip, dtype=np.float64)[:, :2]
        self.shin_slope = self._shin_slope(p.shin_foot_ahead_m)
        self.stairs_shin_slope = self._shin_slope(p.stairs.shin_foot_ahead_m)
        self.on_stairs = False  # in the stairs mode (see StairsMode)
        self.on_stones = False  # in the stepping-stones mode (see StonesMode)
        self._swing_default: Any = None  # the swing planner's parameters off stairs (set by attach)
        self._replan_default = 0.0  # the handler's replan_height_from_plan_m off stairs (set by attach)
        self._swing_stairs: Any = None
        self.maps: TerrainMaps | None = None
        self.path: BodyPath | None = None
        self.cadence: CadenceScore | None = None
        self.speed_cap = p.max_speed_mps
        self.climb_speed: float | None = None  # speed on steps (riser pitch per climb-gait cycle), m/s
        self.last_plan: StepPlan | None = None
        self._t_last_plan = -np.inf
        self.stats = NavigatorStats()
        # The studio's map outlines, made once per maps object (see overlays), and where the body was at its scan.
        self._overlay_maps: TerrainMaps | None = None
        self._overlay_outlines: dict[str, dict[str, Any]] = {}
        self._scan_xy = np.zeros(2)
        self._truth_center: NDArray[np.float64] | None = None
        self._truth_maps: TerrainMaps | None = None
        self._t_path = -np.inf
        self.fast_gait = str(controller.gait)
        # Remembered overhangs: cells (memory_cell_m grid) and their height (m, world).
        self._ceiling_keys = np.zeros((0, 2), dtype=np.int64)
        self._ceiling_z = np.zeros(0)
        # The last refined touchdown of each swinging leg: (touchdown time s, place (3,) m); nan: none.
        self._held_t = np.full(4, np.nan)
        self._held_p = np.full((4, 3), np.nan)
        # Held touchdown targets of the swinging legs (world, m), nan when none.
        self._held_swing = np.full((4, 3), np.nan)
        # the offsets across the heading at which the stairs' corridor is looked for, every 2 cm
        c = self.params.stairs.center_m
        self._center_offsets = np.linspace(-c, c, 2 * int(round(c / 0.02)) + 1)
        self.holds = 0
        # Stairs: the risers along the right and left feet's lines (see planning.terrain.treads), the last stance
        # place of each foot (m, world) and each swing's chosen touchdown (time s, place (3,) m; nan: none).
        self._tread_lines: tuple[TreadLine, TreadLine] | None = None
        self.descending = False  # in the stairs mode, with only dropping risers left ahead of the hind hips
        self._stance_xy = np.full((4, 2), np.nan)
        self._tread_t = np.full(4, np.nan)
        self._tread_p = np.full((4, 3), np.nan)

    def _shin_slope(self, foot_ahead_m: float) -> float:
        """The stance shin's slope (m back per m up) with the foot foot_ahead_m ahead of its nominal place."""
        q0 = np.asarray(self.robot.q_nominal[0], dtype=np.float64)
        foot = self.robot.fk_leg(0, q0) + np.array([foot_ahead_m, 0.0, 0.0])
        knee = self.robot.knee_body(0, self.robot.ik_leg(0, foot))
        return float(max(foot[0] - knee[0], 1e-3) / max(knee[2] - foot[2], 1e-3))

    # ---- wiring ---------------------------------------------------------------------------------------------
    def attach(self) -> None:
        """Sets the controller's hooks and adds the perception and body-path stages in front of its stages."""
        c = self.controller
        c.command_source = self.command
        c.foothold_filter = self.refine
        swing = c.handler.swing_planner
        sw = self._swing_default = dataclasses.replace(
            swing.params, late_descent_gain_per_s=self.params.late_descent_gain_per_s
        )
        swing.set_params(sw)
        self._replan_default = c.handler.params.replan_height_from_plan_m
        scale = sw.a_max_z_mps2 / float(self.params.stairs.swing.get("a_max_z_mps2", sw.a_max_z_mps2))
        family = tuple(dataclasses.replace(v, accel_frac=v.accel_frac * scale) for v in sw.vertical_family)
        self._swing_stairs = dataclasses.replace(sw, vertical_family=family, **self.params.stairs.swing)
        if self.goal is not None:
            c.set_goal(*self.goal)
        c.navigator_overlays = self.overlays
        stages = [
            Stage("perception", self.params.perception_rate_hz, self._perceive),
            Stage("body_path", self.params.path_rate_hz * 5, self._body_path),
        ]
        c.stages[:0] = stages

    # ---- stages ---------------------------------------------------------------------------------------------
    def _perceive(self, s: RobotState) -> None:
        p = self.params
        maps: TerrainMaps | None
        map_params = self.stones_maps if self.on_stones else p.perception.maps
        if self.perception is not None:
            maps = self.perception.scan_now(self.data, map_params)
            assert self.perception.last_cloud is not None
            self.stats.cloud_points.append(self.perception.last_cloud.size)
        else:
            xy = s.p_world_body[:2]
            if self._truth_center is None or np.linalg.norm(xy - self._truth_center) > p.truth_recenter_m:
                assert self.scene is not None
                self._truth_center = xy.copy()
                self._truth_maps = maps_from_scene(
                    self.scene, (float(xy[0]), float(xy[1])), p.truth_half_extent_m, params=map_params
                )
            maps = self._truth_maps
        assert maps is not None
        st = self.on_stairs
        sto = self.on_stones
        maps = with_keepouts(
            maps,
            s.yaw,
            self.stairs_shin_slope if st else self.shin_slope,
            p.stairs.shin_radius_m if st else p.shin_radius_m,
            p.shin_reach_m,
            p.stones.foot_margin_m if sto else p.foot_margin_m,
            min_rise_m=p.stairs.shin_min_rise_m if st else p.shin_min_rise_m,
            riser_margin_m=p.riser_margin_m,
            riser_height_m=p.riser_height_m,
            riser_reach_m=p.riser_reach_m,
            riser_rise_m=p.riser_rise_m,
            drop_reach_m=p.stones.drop_reach_m if sto else p.drop_reach_m,
        )
        self.maps = maps
        self.controller.maps = maps
        self._scan_xy = s.p_world_body[:2].copy()
        self.stats.scans += 1
        self._update_height(s)
        self.controller.height += self._ground_offset(s)
        self._update_pitch(s)
        self._update_gait(s)

    def _update_pitch(self, s: RobotState) -> None:
        """Pitches the body target along the ground slope under the body's heading (nose up going uphill).

        The slope is the rise from the ground behind the body to the ground ahead (around the rear and the front
        feet), each side the highest steppable cell of a few samples (a pit between stones is no ground to stand
        on); the target moves toward it at most max_pitch_rate_rps.
        """
        p = self.params
        maps = self.maps
        assert maps is not None
        d = np.array([0.15, 0.3, 0.45])
        lat = np.array([-0.165, 0.165])
        grid = np.stack(np.broadcast_arrays(d[:, None], lat[None, :]), -1).reshape(-1, 2)
        ends = []
        for sign in (1.0, -1.0):
            xy = s.p_world_body[:2] + rotate_yaw(s.yaw, grid * np.array([sign, 1.0]))
            h = np.asarray(maps.height_at(xy[:, 0], xy[:, 1]), dtype=np.float64)
            ok = ~np.asarray(maps.no_step(xy[:, 0], xy[:, 1]), dtype=bool)
            ends.append(float(np.mean(h[ok])) if np.any(ok) else np.nan)
        rise = ends[0] - ends[1]
        target = 0.0 if not np.isfinite(rise) else -float(np.arctan2(rise, 2.0 * d[1]))
        if self.on_stairs and self.descending and p.stairs.pitch_from_feet:
            feet = self.controller.handler.p_contact
            heading = np.array([np.cos(s.yaw), np.sin(s.yaw)])
            run = 0.5 * float((feet[0, :2] + feet[1, :2] - feet[2, :2] - feet[3, :2]) @ heading)
            if run > 0.2:  # feet spread along the heading as in a stance (not mid-turn or crossed)
                target = -float(np.arctan2(0.5 * (feet[0, 2] + feet[1, 2] - feet[2, 2] - feet[3, 2]), run))
        target = float(np.clip(target, -p.max_pitch_rad, p.max_pitch_rad))
        c = self.controller
        step = p.max_pitch_rate_rps / p.perception_rate_hz
        c.pitch = float(c.pitch + np.clip(target - c.pitch, -step, step))

    def _update_gait(self, s: RobotState) -> None:
        """Switches the controller to the climb gait where the ground under the feet's lines has steps, else to the
        slow gait where the step-obstacle map ahead is dense, and back to its own gait (with hysteresis)."""
        p = self.params
        share = self._dense_share(s.p_world_body[:2], s.yaw)
        c = self.controller
        # the feet's lines once, over the longer of the climb and the stairs windows (both from climb_behind_m)
        ahead = max(p.climb_ahead_m, p.stairs.ahead_m)
        h_all = self._feet_lines(s.p_world_body[:2], s.yaw, p.climb_behind_m, ahead)
        res = self.maps.resolution_m if self.maps is not None else 1.0
        pitch = None
        if h_all is not None and p.climb_gait is not None:
            n_climb = np.arange(-p.climb_behind_m, p.climb_ahead_m + 1e-9, res).size
            pitch = riser_pitch(h_all[:, :n_climb], res, p.climb_rise_m, p.climb_ahead_m + p.climb_behind_m)
        self._update_stones(s, res)
        h_stairs = None
        if h_all is not None and not self.on_stones:
            h_stairs = h_all[:, : np.arange(-p.climb_behind_m, p.stairs.ahead_m + 1e-9, res).size]
        self._update_stairs(h_stairs, res)
        self._update_treads(s, h_all, res)
        c.swing_maps = None
        if self._tread_lines is not None and self.maps is not None and p.stairs.shin_reach_m > 0.0:
            c.swing_maps = shin_ground(self.maps, self._tread_lines[0].heading, p.stairs.shin_reach_m)
        if self.on_stones:
            want = p.stones.gait
            self.climb_speed = p.stones.speed_mps
        elif pitch is not None:
            assert p.climb_gait is not None
            want = p.stairs.gait if self.on_stairs and p.stairs.gait else p.climb_gait
            if self.on_stairs and self.descending and p.stairs.descent_gait:
                want = p.stairs.descent_gait
            # one tread per step: the body moves one riser pitch per gait cycle
            g = get_gait(want)
            speed = pitch / (g.cycle_s * p.climb_steps_per_tread)
            self.climb_speed = float(np.clip(speed, p.min_speed_mps, g.max_speed_mps))
        elif share > p.slow_gait_on:
            want = p.slow_gait
        elif p.stay_slow and c.gait == p.slow_gait:
            want = p.slow_gait
        elif share < p.slow_gait_off:
            want = self.fast_gait
        else:
            want = p.slow_gait if c.gait == p.climb_gait else c.gait
        if pitch is None and not self.on_stones:
            self.climb_speed = None
        if want != c.gait:
            c.set_gait(want)
            self.stats.gait_switches += 1

    def _feet_lines(
        self, xy: NDArray[np.float64], yaw: float, behind_m: float, ahead_m: float
    ) -> NDArray[np.float64] | None:
        """Gives the ground height (2, N) along the left and right feet's lines, behind_m behind to ahead_m ahead
        of the body (heading yaw), one sample per map cell; None without maps."""
        maps = self.maps
        if maps is None:
            return None
        res = maps.resolution_m
        d = np.arange(-behind_m, ahead_m + 1e-9, res)
        lat = np.array([-0.165, 0.165])
        pts = xy + rotate_yaw(yaw, np.stack(np.broadcast_arrays(d[None, :], lat[:, None]), -1))
        return np.asarray(maps.height_at(pts[..., 0], pts[..., 1]), dtype=np.float64)

    def _update_stairs(self, h: NDArray[np.float64] | None, res: float) -> None:
        """Enters the stairs mode where the feet's lines h (2, N) show a flight of stairs, leaves it once no riser
        is left in them, and sets the swing planner's parameters to match."""
        p = self.params
        st = p.stairs
        was = self.on_stairs
        if not st.enabled or h is None:
            self.on_stairs = False
        elif not was:
            self.on_stairs = stair_run(h, res, p.climb_rise_m, st.max_tread_m) >= st.min_risers
        else:
            self.on_stairs = riser_pitch(h, res, p.climb_rise_m, 1.0) is not None
        if self.on_stairs:
            self.stats.stairs_mode_s += 1.0 / p.perception_rate_hz
        if self.on_stairs != was and self._swing_default is not None:
            handler = self.controller.handler
            handler.swing_planner.set_params(self._swing_stairs if self.on_stairs else self._swing_default)
            handler.params = dataclasses.replace(
                handler.params,
                replan_height_from_plan_m=st.replan_height_from_plan_m
                if self.on_stairs
                else self._replan_default,
            )

    def _update_treads(self, s: RobotState, h: NDArray[np.float64] | None, res: float) -> None:
        """In the stairs mode with tread footholds, reads the risers along the right and left feet's lines h (2, N)
        (sampled every res m from climb_behind_m behind the body); else forgets them."""
        p = self.params
        if not self.on_stairs or p.stairs.treads is None or h is None:
            self._tread_lines = None
            self.descending = False
            return
        heading = np.array([np.cos(s.yaw), np.sin(s.yaw)])
        xy = s.p_world_body[:2]
        right, left = (tread_line(row, -p.climb_behind_m, res, p.climb_rise_m, xy, heading) for row in h)
        self._tread_lines = (right, left)
        # going down: of the risers ahead of the hind hips, some drop and none rises (the lines start at the body)
        u_hind = float(np.min(self.p_body_hip_xy[:, 0]))
        ahead = np.concatenate([line.signs[line.risers > u_hind - 0.15] for line in (right, left)])
        self.descending = bool(np.any(ahead < 0) and not np.any(ahead > 0))
        if self.descending:
            self.stats.stairs_descent_s += 1.0 / p.perception_rate_hz

    def _update_stones(self, s: RobotState, res: float) -> None:
        """Enters the stepping-stones mode while either foot line shows a pit ahead (see StonesMode), leaves it
        once none is left."""
        st = self.params.stones
        h = None
        if st.enabled:
            h = self._feet_lines(s.p_world_body[:2], s.yaw, st.behind_m, st.ahead_m)
        if h is None:
            self.on_stones = False
            return
        z_feet = float(np.mean(s.p_world_foot[:, 2])) - float(self.robot.foot_radius_m)
        self.on_stones = pit_between(h, z_feet, st.drop_m, st.return_m)
        if self.on_stones:
            self.stats.stones_mode_s += 1.0 / self.params.perception_rate_hz

    def _body_path(self, s: RobotState) -> None:
        """Replans the body path at path_rate_hz, and sooner when the current path's sweep hits an obstacle."""
        if self.maps is None or self.goal is None:
            return
        due = s.t - self._t_path >= 1.0 / self.params.path_rate_hz - 1e-9
        if not due and self.path is not None:
            if sweep_clearance(self.maps, self._remaining(s), self.params.path) >= 0.0:
                return
        self._t_path = s.t
        self.replan(s)

    def replan(self, s: RobotState) -> BodyPath:
        """Plans the body path from the body to the goal on the current maps and chooses the cadence on it."""
        assert self.goal is not None, "replan: a steered navigator has no goal"
        path = plan_body_path(self.maps, s.p_world_body[:2], s.yaw, self.goal, self.params.path)
        self.path = path
        self.stats.body_paths += 1
        if not path.valid:
            self.stats.invalid_paths += 1
        best, _ = choose_cadence(path, self.maps, self.cadence_params)
        self.cadence = best
        self.stats.cadences[best.cadence.name] = self.stats.cadences.get(best.cadence.name, 0) + 1
        self.speed_cap = min(self.params.max_speed_mps, best.cadence.speed_mps)
        return path

    def overlays(self) -> dict[str, dict[str, Any]]:
        """The studio's terrain overlays (planning.terrain.overlays): the maps' outlines around the body, the body
        path, the step QP's footholds while it refines them (solved within overlay_plan_s) and the last depth scan."""
        maps = self.maps
        if maps is None:
            return {}
        if self._overlay_maps is not maps:
            self._overlay_maps = maps
            self._overlay_outlines = map_overlays(maps, self._scan_xy)
        fresh = float(self.data.time) - self._t_last_plan <= self.params.overlay_plan_s
        cloud = self.perception.last_cloud if self.perception is not None else None
        return {
            **self._overlay_outlines,
            **plan_overlays(maps, self.path, self.last_plan if fresh else None, cloud),
        }

    def _remaining(self, s: RobotState) -> BodyPath:
        """The current path from the point nearest the body on (for the sweep check)."""
        assert self.path is not None
        path = self.path
        k = int(np.argmin(np.sum((path.xy - s.p_world_body[:2]) ** 2, axis=1)))
        k = min(k, len(path.s) - 1)
        return BodyPath(path.xy[k:], path.yaw[k:], path.s[k:] - path.s[k], path.method, path.valid, np.inf)

    # ---- body height ----------------------------------------------------------------------------------------
    def _update_height(self, s: RobotState) -> None:
        """Lowers the body height target under overhangs (the clearance map around and ahead of the body).

        Overhangs count by their height above the ground the robot stands on (the mean foot height, or the
        ground under the sample when higher), not above their own cell's ground: over a pit, the side of a
        stepping stone seen from afar would otherwise look like a low ceiling.
        """
        p = self.params
        maps = self.maps
        assert maps is not None
        yaw = s.yaw
        d = np.linspace(-p.crouch_ahead_m, p.crouch_ahead_m, 15)
        lat = np.array([-0.12, 0.0, 0.12])
        xy = s.p_world_body[:2] + rotate_yaw(yaw, np.stack(np.broadcast_arrays(d[:, None], lat[None, :]), -1))
        xy = xy.reshape(-1, 2)
        # Only overhangs with room under them count: a tall box's column is a wall (a body obstacle), not a ceiling.
        c = np.asarray(maps.clearance_at(xy[:, 0], xy[:, 1]), dtype=np.float64)
        wall = np.asarray(maps.no_body(xy[:, 0], xy[:, 1]), dtype=bool)
        h_cell = np.asarray(maps.height_at(xy[:, 0], xy[:, 1]), dtype=np.float64)
        z_ceiling = np.where(wall, np.inf, h_cell + c)
        z_feet = float(np.mean(s.p_world_foot[:, 2])) - float(self.robot.foot_radius_m)
        z_ground = np.maximum(h_cell, z_feet)
        rel = z_ceiling - z_ground
        clear = np.where(rel >= p.perception.maps.ceiling_above_m, rel, np.inf)
        clear_now = min(
            float(np.min(clear)), self._remembered_clearance(s.p_world_body[:2], xy, z_ceiling, yaw, z_feet)
        )
        h = self.standing_height
        if np.isfinite(clear_now):
            h = min(h, clear_now - p.body_top_m - p.head_margin_m)
        h = float(np.clip(h, p.min_height_m, self.standing_height))
        self.stats.min_height_m = min(self.stats.min_height_m, h)
        self.controller.height = h

    def _ground_offset(self, s: RobotState) -> float:
        """Gives how much lower (m, ≤ 0) the ground under the hips is than the feet (the controller holds the
        body at its height above the mean foot): going down stairs the feet trail the hips by half a step, a riser
        higher, and the front legs would reach down at full stretch. At most hip_ground_max_m; 0 below
        hip_ground_min_m (flat, rough). (Going up, a higher body measured so lifted the hind legs off: not used.)"""
        p = self.params
        maps = self.maps
        if maps is None or p.hip_ground_max_m <= 0.0 or self.on_stones:
            return 0.0  # (over stones the ground under the hips is the pit, not ground to stand on)
        xy = s.p_world_body[:2] + rotate_yaw(s.yaw, self.p_body_hip_xy)
        h = np.asarray(maps.height_at(xy[:, 0], xy[:, 1]), dtype=np.float64)
        z_feet = float(np.mean(self.controller.handler.p_contact[:, 2]))  # what the height is measured from
        off = float(np.mean(h)) - z_feet
        if abs(off) < p.hip_ground_min_m:
            return 0.0
        return float(np.clip(off, -p.hip_ground_max_m, 0.0))

    def _remembered_clearance(
        self,
        p_body_xy: NDArray[np.float64],
        xy: NDArray[np.float64],
        z_ceiling: NDArray[np.float64],
        yaw: float,
        z_ground: float,
    ) -> float:
        """Gives the lowest remembered clearance (m) above z_ground in the crouch window around the body (heading
        yaw, rad), after adding the overhang samples at xy (M, 2) (world, m) with their heights z_ceiling (M,).

        The sensor sees an overhang only from a distance (its rays leave the body at most a little above the
        horizon), and the voxel map forgets what it no longer sees: under a table the top above the body drops out
        of the maps. Overhangs do not come and go, so their samples are kept (on a memory_cell_m grid, the lowest
        per cell) and looked up in the same window around the body.
        """
        p = self.params
        seen = np.isfinite(z_ceiling)
        if np.any(seen):
            keys = np.rint(xy[seen] / p.memory_cell_m).astype(np.int64)
            mem_k = np.concatenate([self._ceiling_keys, keys])
            mem_z = np.concatenate([self._ceiling_z, z_ceiling[seen]])
            order = np.lexsort((mem_z, mem_k[:, 1], mem_k[:, 0]))
            mem_k, mem_z = mem_k[order], mem_z[order]
            first = np.ones(len(mem_z), dtype=bool)
            first[1:] = np.any(mem_k[1:] != mem_k[:-1], axis=1)
            self._ceiling_keys, self._ceiling_z = mem_k[first], mem_z[first]
        if self._ceiling_z.size == 0:
            return np.inf
        d_body = rotate_yaw(-yaw, self._ceiling_keys * p.memory_cell_m - p_body_xy)
        rel = self._ceiling_z - z_ground
        near = (
            (np.abs(d_body[:, 0]) <= p.crouch_ahead_m)
            & (np.abs(d_body[:, 1]) <= p.crouch_side_m)
            & (rel >= p.perception.maps.ceiling_above_m)
        )
        return float(np.min(rel[near])) if np.any(near) else np.inf

    # ---- hooks ----------------------------------------------------------------------------------------------
    def command(self, s: RobotState) -> SteeringCommand:
        """Gives the steering command (body frame) that follows the body path toward the goal; when steered, the
        controller's own command within the terrain's speed limits (see steered_command)."""
        p = self.params
        if self.goal is None:
            return self.steered_command(s)
        xy = s.p_world_body[:2]
        d_goal = self.goal - xy
        dist = float(np.linalg.norm(d_goal))
        if dist < p.goal_tolerance_m:
            return SteeringCommand()
        speed = min(self.speed_cap, p.goal_gain * dist)
        if self.controller.gait == p.slow_gait:
            speed = min(speed, p.slow_gait_speed_mps)
        if self.path is None or self.path.length_m < 1e-6:
            target = self.goal
            yaw_des = s.yaw
        else:
            path = self.path
            k = int(np.argmin(np.sum((path.xy - xy) ** 2, axis=1)))
            s_ahead = float(path.s[k]) + p.lookahead_m
            target_a, yaw_a = path.pose_at(s_ahead)
            target = target_a if s_ahead < path.length_m else self.goal
            yaw_des = float(path.yaw[k]) if dist > 0.5 else s.yaw
            if self.climb_speed is not None:
                speed = min(self.climb_speed * self._tread_pace(s), p.goal_gain * dist)
            else:
                speed *= self._dense_slowdown(xy, s.yaw) * self._lag_slowdown(s)
            del yaw_a
            climbing = self.on_stairs and not self.descending and p.stairs.center_m > 0.0
            if climbing and self.maps is not None and s_ahead < path.length_m:  # a path point, not the goal
                target = target + corridor_middle(self.maps.sdf_body, target, s.yaw, self._center_offsets)
        d = target - xy
        n = float(np.linalg.norm(d))
        if n < 1e-9:
            return SteeringCommand()
        v_world = d / n * max(speed, 0.0)
        v_body = rotate_yaw(-s.yaw, v_world)
        dyaw = float((yaw_des - s.yaw + np.pi) % (2 * np.pi) - np.pi)
        wz = float(np.clip(p.yaw_gain * dyaw, -p.max_yaw_rate_rps, p.max_yaw_rate_rps))
        if not (self.on_stones or self.on_stairs) and p.keep_heading_m > 0.0:
            vx, vy = float(v_body[0]), float(v_body[1])
            clipped = self.controller.planner.steering.limit(
                SteeringCommand(vx, vy, wz), self._steered_gait()
            )
            keep = direction_kept(vx, vy, clipped)
            if keep < 1.0 and self._swept_clearance(s, clipped.vx, clipped.vy, wz) < p.keep_heading_m:
                v_body *= keep
        return SteeringCommand(float(v_body[0]), float(v_body[1]), wz)

    def _steered_gait(self) -> Gait:
        """The gait whose steering limits apply: the one walked or about to be (the walk gait from a stand)."""
        planner = self.controller.planner
        gait = planner.clock.pending or planner.clock.gait
        return planner.walk_gait if gait.is_stand else gait

    def steered_command(self, s: RobotState) -> SteeringCommand:
        """Gives the operator's velocity command (the controller's, body frame) with its speed capped where the
        terrain asks for it: one tread per step on stairs (climb speed), the stones speed, the slow gait's cap, and
        slower where the step-obstacle map ahead is dense; the yaw rate within max_yaw_rate_rps."""
        p = self.params
        cmd = self.controller.command
        cap = p.max_speed_mps * self._dense_slowdown(s.p_world_body[:2], s.yaw) * self._lag_slowdown(s)
        if self.climb_speed is not None:
            cap = self.climb_speed * self._tread_pace(s)
        elif self.controller.gait == p.slow_gait:
            cap = min(cap, p.slow_gait_speed_mps)
        speed = float(np.hypot(cmd.vx, cmd.vy))
        k = min(1.0, cap / speed) if speed > 1e-9 else 1.0
        wz = float(np.clip(cmd.yaw_rate, -p.max_yaw_rate_rps, p.max_yaw_rate_rps))
        k *= self._obstacle_stop(s, cmd.vx * k, cmd.vy * k, wz)
        return SteeringCommand(cmd.vx * k, cmd.vy * k, wz)

    def _tread_pace(self, s: RobotState) -> float:
        """On stairs with tread footholds, the factor on the climb speed that keeps the body over its feet: the
        body speeds up while the feet (stance places and the swings' chosen touchdowns) are ahead of it and slows
        down while they lag, by StairsMode.pace_gain_per_s per m, within StairsMode.pace_range; 1 elsewhere."""
        st = self.params.stairs
        lines = self._tread_lines
        if lines is None or self.climb_speed is None or self.climb_speed <= 0.0:
            return 1.0
        feet = s.p_world_foot[:, :2].copy()
        held = np.isfinite(self._tread_t)
        feet[held] = self._tread_p[held, :2]
        h = lines[0].heading
        ahead = float(np.mean((feet - s.p_world_body[:2]) @ h))
        hips = s.p_world_body[:2] + rotate_yaw(s.yaw, self.p_body_hip_xy)
        lag = max(float(np.max((hips - feet) @ h)) - st.pace_lag_m, 0.0)
        lo, hi = st.pace_range
        return float(np.clip(1.0 + st.pace_gain_per_s * (ahead - lag) / self.climb_speed, lo, hi))

    def _lag_slowdown(self, s: RobotState) -> float:
        """Gives the factor (0 to 1) on the speed from how far the stance foot farthest behind its hip trails it
        along the heading (see NavigatorParams.lag_slow_m); 1 with no foot down."""
        lo, hi = self.params.lag_slow_m
        stance = self.controller.handler.stance
        if hi <= lo or not stance.any():
            return 1.0
        h = np.array([np.cos(s.yaw), np.sin(s.yaw)])
        hips = s.p_world_body[:2] + rotate_yaw(s.yaw, self.p_body_hip_xy)
        lag = float(np.max(((hips - s.p_world_foot[:, :2]) @ h)[stance]))
        return float(np.clip((hi - lag) / (hi - lo), 0.0, 1.0))

    def _obstacle_stop(self, s: RobotState, vx: float, vy: float, wz: float) -> float:
        """Gives the largest of 1, 3/4, 1/2, 1/4, 0 by which the steered velocity (body frame, m/s, rad/s) may be
        scaled so the body's footprint, swept over the next stop_horizon_s, keeps stop_margin_m from the
        body-obstacle map (or does not come closer than it is now): steering stops short of a wall, a table leg or
        a tall box instead of walking into it."""
        p = self.params
        if self.maps is None or p.stop_horizon_s <= 0.0 or (abs(vx) < 1e-6 and abs(vy) < 1e-6):
            return 1.0
        need = min(p.stop_margin_m, self._swept_clearance(s, 0.0, 0.0, 0.0))
        for f in (1.0, 0.75, 0.5, 0.25):
            if self._swept_clearance(s, vx * f, vy * f, wz) >= need - 1e-3:
                return f
        return 0.0

    def _swept_clearance(self, s: RobotState, vx: float, vy: float, wz: float) -> float:
        """Gives the smallest clearance (m) from the body-obstacle map of the body's footprint swept over the
        next stop_horizon_s at the body-frame velocity (m/s, rad/s); +inf without maps."""
        p = self.params
        maps = self.maps
        if maps is None:
            return float("inf")
        fp, r = p.path.footprint_x_m, p.path.footprint_r_m
        t = np.linspace(0.0, p.stop_horizon_s, 7)
        v_world = rotate_yaw(s.yaw, np.array([vx, vy]))
        xy = s.p_world_body[:2] + t[:, None] * v_world[None, :]
        return float(np.min(sweep_points_clearance(maps, xy, s.yaw + wz * t, fp))) - r

    def _dense_share(self, xy: NDArray[np.float64], yaw: float) -> float:
        """Gives the no-step share of the dense_radius_m disk ahead of the body (0 without maps)."""
        p = self.params
        maps = self.maps
        if maps is None:
            return 0.0
        r = np.linspace(-p.dense_radius_m, p.dense_radius_m, 9)
        pts = xy + rotate_yaw(yaw, np.array([p.dense_radius_m * 0.5, 0.0])) + np.stack(np.meshgrid(r, r), -1)
        inside = np.hypot(*np.moveaxis(pts - pts[4, 4], -1, 0)) <= p.dense_radius_m
        return float(np.mean(np.asarray(maps.no_step(pts[..., 0], pts[..., 1]), dtype=bool)[inside]))

    def _dense_slowdown(self, xy: NDArray[np.float64], yaw: float) -> float:
        """Gives a speed factor in [min/max, 1]: lower where the step-obstacle map ahead is dense."""
        p = self.params
        share = self._dense_share(xy, yaw)
        lo = p.min_speed_mps / max(p.max_speed_mps, 1e-9)
        return float(1.0 - (1.0 - lo) * min(share / max(p.dense_full, 1e-9), 1.0))

    def refine(self, s: RobotState, sel: Selection) -> Selection:
        """Gives the selection with its footholds refined by the step QP when any lies on or near a no-step cell,
        and the swinging feet's targets held against jumps (see NavigatorParams.hold_jump_m)."""
        if self._tread_lines is not None:
            return self._tread_footholds(s, sel)
        self._tread_t[:] = np.nan
        sel = self._refine_qp(s, sel)
        if self.on_stairs and not self.params.stairs.hold_swing_targets:
            self._held_swing[:] = np.nan
            return sel
        return self._hold_swing_targets(sel)

    def _tread_footholds(self, s: RobotState, sel: Selection) -> Selection:
        """The selection with every touchdown moved along the heading onto a tread (see planning.terrain.treads):
        each swing lands on its own tread or the next, chosen once at liftoff and held to touchdown; a later
        touchdown steps on from the one before it."""
        lines = self._tread_lines
        maps = self.maps
        assert lines is not None and maps is not None
        margins = self.params.stairs.treads
        assert margins is not None
        path = sel.path
        swinging = np.isnan(path.t_liftoff_now)
        self._stance_xy[~swinging] = s.p_world_foot[~swinging, :2]
        t_td, _ = path.next_touchdowns()
        p_new = path.p_world_touchdown.copy()
        last_xy = self._stance_xy.copy()
        # a chosen touchdown is forgotten once its leg is down or its swing lands at another time
        self._tread_t[~swinging | ~(np.abs(self._tread_t - t_td) < 0.15)] = np.nan
        for k in range(path.n_touchdowns):
            leg = int(path.leg[k])
            line = lines[1 if leg in (0, 2) else 0]  # FL, RL on the left line
            first = bool(swinging[leg]) and abs(float(path.t_touchdown[k]) - float(t_td[leg])) < 1e-9
            nom = p_new[k, :2].copy()
            u_nom = float(line.u(nom))
            if first and np.isfinite(self._tread_t[leg]):
                # the tread chosen at liftoff; the place along it follows the selection within its window
                lo, hi = line.window(line.segment(float(line.u(self._tread_p[leg, :2]))), margins)
                u = float(np.clip(u_nom, lo, hi))
            else:
                from_xy = last_xy[leg] if np.all(np.isfinite(last_xy[leg])) else s.p_world_foot[leg, :2]
                u = choose_tread(line, float(line.u(from_xy)), u_nom, margins)
            if first and self.params.stairs.shin_clear_m > 0.0:
                u = self._shin_clear(s, line, leg, u, float(path.t_touchdown[k]), nom)
            p_new[k, :2] = nom + (u - u_nom) * line.heading
            if first and not np.isfinite(self._tread_t[leg]):
                self._tread_t[leg] = t_td[leg]
                self._tread_p[leg] = p_new[k]
            last_xy[leg] = p_new[k, :2]
        p_new[:, 2] = maps.height_at(p_new[:, 0], p_new[:, 1])
        return dataclasses.replace(sel, path=path.with_touchdowns(p_new, path.kind + "+treads"))

    def _shin_clear(
        self, s: RobotState, line: TreadLine, leg: int, u: float, t_td: float, nom: NDArray[np.float64]
    ) -> float:
        """Gives where along its tread (m along line) a foot stepping down lands: u, or the nearest place in its
        window where its shin clears the nosing above by StairsMode.shin_clear_m, the hip taken where it will be
        at touchdown (t_td, s): moved along the heading at the body's speed and down the slope the body is pitched
        to (see treads.clear_of_nosing). u as it is where the tread has no drop behind it."""
        maps = self.maps
        margins = self.params.stairs.treads
        assert maps is not None and margins is not None
        j = line.segment(u)
        if j == 0 or line.signs[j - 1] > 0:
            return u
        r = float(line.risers[j - 1])
        side = nom - line.origin - float(line.u(nom)) * line.heading  # the foot's offset across the line
        up = line.origin + (r - 0.06) * line.heading + side
        down = line.origin + (r + 0.06) * line.heading + side
        z_up = float(maps.height_at(up[0], up[1]))
        z_down = float(maps.height_at(down[0], down[1]))
        if not (np.isfinite(z_up) and np.isfinite(z_down)) or z_up - z_down < 0.05:
            return u
        lo, hi = line.window(j, margins)
        hip = s.p_world_body + s.R_world_body @ self.robot.p_body_hip[leg]
        dt = max(t_td - s.t, 0.0)
        v = float(s.v_world_body[:2] @ line.heading)
        hip_uz = np.array(
            [
                float(line.u(hip[:2])) + v * dt,
                float(hip[2]) - np.tan(max(self.controller.pitch, 0.0)) * v * dt,
            ]
        )
        return clear_of_nosing(
            u,
            (lo, min(hi, r + 0.45)),  # the floor after the flight has no far end: at most 45 cm on
            hip_uz,
            z_down + float(self.robot.foot_radius_m),
            np.array([r, z_up]),
            float(self.robot.l_upper),
            float(self.robot.l_lower),
            self.params.stairs.shin_clear_m,
        )

    def _hold_swing_targets(self, sel: Selection) -> Selection:
        p = self.params
        maps = self.maps
        path = sel.path
        swinging = np.isnan(path.t_liftoff_now)
        self._held_swing[~swinging] = np.nan
        if maps is None or not swinging.any():
            return sel
        p_new: NDArray[np.float64] | None = None
        for leg in np.flatnonzero(swinging):
            ks = np.flatnonzero(path.leg == leg)
            if ks.size == 0:
                continue
            k = int(ks[np.argmin(path.t_touchdown[ks])])
            target = path.p_world_touchdown[k]
            held = self._held_swing[leg]
            if np.isfinite(held[0]):
                jump = float(np.hypot(*(target[:2] - held[:2])))
                ok = float(maps.sdf_step(held[0], held[1])) >= p.hold_min_sdf_m
                if p.hold_jump_m < jump <= p.hold_radius_m and ok:
                    if p_new is None:
                        p_new = path.p_world_touchdown.copy()
                    p_new[k] = held
                    self.holds += 1
                    continue
            self._held_swing[leg] = target
        if p_new is None:
            return sel
        return dataclasses.replace(sel, path=path.with_touchdowns(p_new, path.kind + "+hold"))

    def _refine_qp(self, s: RobotState, sel: Selection) -> Selection:
        """The selection with its footholds refined by the step QP (see refine).

        A swinging leg whose touchdown the QP moved keeps that refined place while the QP cannot move it again
        (too close to touchdown, or no answer): falling back to the unrefined place mid-swing would send the foot
        back onto the no-step cell it was steered away from (a riser's foot, behind a step it already rose over).
        """
        maps = self.maps
        path = sel.path
        if maps is None or path.n_touchdowns < 4:
            return sel
        K = self.qp.K
        order = np.lexsort((path.leg, path.t_touchdown))[:K]
        if order.size < K:
            return sel
        xy = path.p_world_touchdown[order, :2]
        sd = np.asarray(maps.sdf_step(xy[:, 0], xy[:, 1]), dtype=np.float64)
        on_map = np.asarray(maps.in_map(xy[:, 0], xy[:, 1]), dtype=bool)
        if not np.any(on_map & (sd < self.params.qp_trigger_m)):
            self._held_t[:] = np.nan
            return sel
        p_new = path.p_world_touchdown.copy()
        moved = np.zeros(len(p_new), dtype=bool)
        req = self._request(s, path, order)
        plan = None
        if req is not None:
            plan = (self.qp_stones if self.on_stones else self.qp).solve(req, maps)
            self.last_plan = plan
            self._t_last_plan = s.t
            self.stats.qp_solves += 1
            self.stats.qp_ms.append(plan.solve_ms)
            self.stats.qp_bare_ms.append(plan.bare_solver_ms)
            bad_hard = set(plan.hard_softened) - {"step_keep"}
            if bad_hard or not np.all(np.isfinite(plan.footholds)):
                plan = None
        if plan is not None and self.on_stones:
            plan = self._pin_snapped(plan, maps)
        if plan is not None:
            t_rel = path.t_touchdown[order] - s.t
            for j, k in enumerate(order):
                if t_rel[j] < self.params.qp_min_time_s:
                    continue  # about to land: too late to move
                if plan.in_no_step[j] and sd[j] >= 0.0:
                    continue  # the QP made it worse
                p_new[k, :2] = plan.footholds[j, :2]
                p_new[k, 2] = float(maps.height_at(plan.footholds[j, 0], plan.footholds[j, 1]))
                moved[k] = True
            self.stats.qp_used += 1
        freeze = self.params.stones.freeze_touchdown_s if self.on_stones else 0.0
        self._hold_refined_targets(path, p_new, moved, s.t, freeze)
        if plan is None and not np.any(moved):
            return sel
        return dataclasses.replace(sel, path=path.with_touchdowns(p_new, path.kind + "+qp"))

    def _pin_snapped(self, plan: StepPlan, maps: TerrainMaps) -> StepPlan:
        """Gives the plan with its footholds replaced by the snapped nominals where those are free by at least
        StonesMode.pin_min_sdf_m (see StonesMode)."""
        lim = self.params.stones.pin_min_sdf_m
        if lim is None or plan.p_nominal is None:
            return plan
        nom = plan.p_nominal
        pin = np.asarray(maps.sdf_step(nom[:, 0], nom[:, 1]), dtype=np.float64) >= lim
        if not np.any(pin):
            return plan
        feet = plan.footholds.copy()
        feet[pin, :2] = nom[pin]
        in_no_step = plan.in_no_step & ~pin
        return dataclasses.replace(plan, footholds=feet, in_no_step=in_no_step)

    def _hold_refined_targets(
        self,
        path: StepPath,
        p_new: NDArray[np.float64],
        moved: NDArray[np.bool_],
        t_now: float = 0.0,
        freeze_s: float = 0.0,
    ) -> None:
        """Keeps each swinging leg's last refined touchdown place where this replan did not refine it (same
        touchdown within 0.15 s), and remembers the refined places (p_new, moved: (K,) in path order, in place).
        freeze_s > 0: a refined place is also kept against a new refinement once its touchdown is less than
        freeze_s (s) after t_now (s)."""
        t_td, _ = path.next_touchdowns()
        first = {int(path.leg[i]): i for i in np.argsort(path.t_touchdown)[::-1]}
        for leg in range(4):
            k = first.get(leg)
            swinging = bool(np.isnan(path.t_liftoff_now[leg]))
            if k is None or not swinging:
                self._held_t[leg] = np.nan
                continue
            same = abs(float(self._held_t[leg]) - float(t_td[leg])) < 0.15
            if moved[k] and freeze_s > 0.0 and same and float(t_td[leg]) - t_now < freeze_s:
                p_new[k] = self._held_p[leg]
            elif moved[k]:
                self._held_t[leg], self._held_p[leg] = t_td[leg], p_new[k]
            elif abs(float(self._held_t[leg]) - float(t_td[leg])) < 0.15:
                p_new[k] = self._held_p[leg]
                moved[k] = True

    def _request(self, s: RobotState, path: StepPath, order: NDArray[np.intp]) -> StepRequest | None:
        """Gives the step QP's request for the path's first K touchdowns (nominal = the selected footholds)."""
        legs = path.leg[order].astype(np.intp)
        K = legs.size
        if any(legs[k] != legs[k - 4] for k in range(4, K)) or sorted(legs[:4].tolist()) != [0, 1, 2, 3]:
            return None
        t_now = s.t
        t_td = path.t_touchdown[order] - t_now
        t_lo = np.empty(K)
        for j, k in enumerate(order):
            leg = int(path.leg[k])
            prev = [i for i in order[:j] if path.leg[i] == leg]
            if prev:
                t_lo[j] = path.t_liftoff[prev[-1]] - t_now
            else:
                lo = path.t_liftoff_now[leg]
                t_lo[j] = -1.0 if np.isnan(lo) else min(float(lo) - t_now, float(t_td[j]) - 1e-3)
        body = path.body
        t_abs = path.t_touchdown[order]
        later = np.array(
            [t_abs[t_abs > t + 1e-6].min() if np.any(t_abs > t + 1e-6) else t + 0.2 for t in t_abs]
        )
        t_mid = 0.5 * (t_abs + later)
        p_hip = body.position(t_abs) + rotate_yaw(body.yaw(t_abs), self.p_body_hip_xy[legs])
        return StepRequest(
            legs=legs,
            t_liftoff=t_lo,
            t_touchdown=np.maximum(t_td, 1e-3),
            p_nominal=path.p_world_touchdown[order, :2].copy(),
            p_hip=p_hip,
            hip_height=np.full(K, float(self.controller.height)),
            c_body=body.position(t_mid),
            yaw_body=np.asarray(body.yaw(t_mid), dtype=np.float64),
            p_feet=s.p_world_foot[:, :2].copy(),
            v_feet=s.v_world_foot[:, :2].copy(),
            t_now=float(t_now),
        )


def corridor_middle(
    sdf_body: Callable[[NDArray[np.float64], NDArray[np.float64]], Any],
    xy: NDArray[np.float64],
    yaw: float,
    offsets: NDArray[np.float64],
) -> NDArray[np.float64]:
    """Gives the shift (2,) m, world, across the heading yaw that brings xy to the middle of the span free of body
    obstacles through it (sdf_body > 0 at the offsets, m, sorted, symmetric about 0): zero when xy is not free or
    the span reaches the end of the offsets on either side (no corridor, nothing to center in)."""
    n = np.array([-np.sin(yaw), np.cos(yaw)])
    free = np.asarray(sdf_body(xy[0] + offsets * n[0], xy[1] + offsets * n[1]), dtype=np.float64) > 0.0
    mid = len(offsets) // 2
    if not free[mid]:
        return np.zeros(2)
    blocked = np.flatnonzero(~free)
    left, right = blocked[blocked < mid], blocked[blocked > mid]
    if left.size == 0 or right.size == 0:
        return np.zeros(2)
    lo, hi = offsets[left[-1] + 1], offsets[right[0] - 1]
    return 0.5 * float(lo + hi) * n


def direction_kept(vx: float, vy: float, clipped: SteeringCommand) -> float:
    """Gives the factor (0 to 1) on a body-frame velocity (m/s) that brings it within the limits its clipped
    version shows (the steering filter clips each component on its own) while keeping its direction: a walk's
    sideways limit (0.19 m/s) would otherwise turn a path's sideways leg around a box into a walk straight on."""
    k = 1.0
    for v, c in ((vx, clipped.vx), (vy, clipped.vy)):
        if v * c > 0.0 and abs(c) < abs(v):
            k = min(k, c / v)
    return k


def pit_between(h: NDArray[np.float64], z_feet: float, drop_m: float, return_m: float) -> bool:
    """Tells whether any of the height profiles h (L, N) (m, world; NaN: unknown) dips more than drop_m below
    z_feet (the ground the feet stand on, m) between two samples within return_m of it (or higher): a pit or gap
    between steppable patches. Stairs (up or down) never dip and come back up; a box rises."""
    for row in h:
        high = np.flatnonzero(row >= z_feet - return_m)
        if high.size < 2:
            continue
        inner = row[high[0] : high[-1]]
        if np.any(inner < z_feet - drop_m):
            return True
    return False


def riser_pitch(h: NDArray[np.float64], res: float, rise_m: float, window_m: float) -> float | None:
    """Gives the median distance (m) between successive risers (see treads.risers_along) along height profiles h (L, N)
    sampled every res m, window_m when only one riser is seen, None when none is."""
    gaps: list[float] = []
    seen = False
    for row in h:
        centers, _ = risers_along(row, res, rise_m)
        if centers.size == 0:
            continue
        seen = True
        gaps.extend(np.diff(centers).tolist())
    if not seen:
        return None
    return float(np.median(gaps)) if gaps else window_m


def stair_run(h: NDArray[np.float64], res: float, rise_m: float, max_tread_m: float) -> int:
    """Gives the longest flight of stairs seen on every one of the height profiles h (L, N) sampled every res m:
    the fewest, over the profiles, of the longest run of successive risers (the height changing by more than rise_m
    within two samples) that all rise or all drop, each within max_tread_m of the one before."""
    best = []
    for row in h:
        x, sign = risers_along(row, res, rise_m)
        if x.size == 0:
            best.append(0)
            continue
        run = longest = 1
        for k in range(1, len(x)):
            run = run + 1 if sign[k] == sign[k - 1] and x[k] - x[k - 1] <= max_tread_m else 1
            longest = max(longest, run)
        best.append(longest)
    return int(min(best)) if best else 0


def shin_keepout(
    maps: TerrainMaps, yaw: float, slope: float, radius_m: float, reach_m: float, min_rise_m: float = 0.03
) -> NDArray[np.bool_]:
    """Gives the cells (nx, ny) where a stance shin would touch the ground behind the foot (heading yaw, rad).

    The shin runs from the foot up and back (against the heading) to the knee: at height z above the foot it lies
    z·slope behind it. Ground at distance d behind a foothold, higher than the foothold by more than
    (d - radius_m)/slope + min_rise_m reaches the shin (radius_m: the shin thickness plus a margin; min_rise_m
    ignores gentle slopes); d up to reach_m.
    """
    h = maps.ground_height
    res = maps.resolution_m
    out = np.zeros(h.shape, dtype=bool)
    c, s = np.cos(yaw), np.sin(yaw)
    nx, ny = h.shape
    ix, iy = np.meshgrid(np.arange(nx), np.arange(ny), indexing="ij")
    for d in np.arange(res, reach_m + 1e-9, res):
        jx = np.clip(np.rint(ix - d * c / res).astype(np.intp), 0, nx - 1)
        jy = np.clip(np.rint(iy - d * s / res).astype(np.intp), 0, ny - 1)
        out |= h[jx, jy] - h > max(d - radius_m, 0.0) / slope + min_rise_m
    return out


def riser_keepout(
    maps: TerrainMaps, yaw: float, reach_m: float, rise_m: float, drop: bool = False
) -> NDArray[np.bool_]:
    """Gives the cells (nx, ny) with a riser ahead: ground within reach_m ahead (along the heading yaw, rad)
    higher than the cell by more than rise_m.

    A foot set down at the foot of a riser has no room to lift before its next swing moves forward (the swing
    clips the riser's edge), and its toe touches the riser face; the seed's no-step regions include such places.
    drop=True: a drop ahead instead (ground lower by more than rise_m): the foot keeps off the nosing going down.
    """
    h = maps.ground_height
    res = maps.resolution_m
    out = np.zeros(h.shape, dtype=bool)
    if reach_m <= 0.0:
        return out
    c, s = np.cos(yaw), np.sin(yaw)
    nx, ny = h.shape
    ix, iy = np.meshgrid(np.arange(nx), np.arange(ny), indexing="ij")
    for d in np.arange(res, reach_m + 1e-9, res):
        jx = np.clip(np.rint(ix + d * c / res).astype(np.intp), 0, nx - 1)
        jy = np.clip(np.rint(iy + d * s / res).astype(np.intp), 0, ny - 1)
        out |= (h - h[jx, jy] if drop else h[jx, jy] - h) > rise_m
    return out


def with_keepouts(
    maps: TerrainMaps,
    yaw: float,
    slope: float,
    radius_m: float,
    reach_m: float,
    foot_margin_m: float,
    min_rise_m: float = 0.03,
    riser_margin_m: float = 0.0,
    riser_height_m: float = 0.04,
    riser_reach_m: float = 0.0,
    riser_rise_m: float = np.inf,
    drop_reach_m: float = 0.0,
) -> TerrainMaps:
    """Gives the maps with the shin keep-out (see shin_keepout) added to the step obstacles and those grown by
    foot_margin_m (the foot's radius: a foot centered just off a box still scrapes its side), plus the cells with
    ground higher by more than riser_height_m within riser_margin_m (m) (the foot sphere and its tracking error
    beside a riser), plus the riser keep-out in
    front of a foothold (see riser_keepout, when riser_reach_m > 0) and before a drop (drop_reach_m); SDF
    recomputed."""
    extra = shin_keepout(maps, yaw, slope, radius_m, reach_m, min_rise_m)
    if riser_reach_m > 0.0 and np.isfinite(riser_rise_m):
        extra |= riser_keepout(maps, yaw, riser_reach_m, riser_rise_m)
    if drop_reach_m > 0.0 and np.isfinite(riser_rise_m):
        extra |= riser_keepout(maps, yaw, drop_reach_m, riser_rise_m, drop=True)
    if riser_margin_m > 0.0:
        h = maps.ground_height
        rc = riser_margin_m / maps.resolution_m
        i = np.arange(-int(rc), int(rc) + 1)
        disk = (i[:, None] ** 2 + i[None, :] ** 2) <= rc * rc + 1e-9
        extra |= ndimage.maximum_filter(h, footprint=disk, mode="nearest") - h > riser_height_m
    step = maps.step_obstacle | extra
    r = int(round(foot_margin_m / maps.resolution_m))
    if r > 0 and step.any():
        i = np.arange(-r, r + 1)
        step = ndimage.binary_dilation(step, structure=(i[:, None] ** 2 + i[None, :] ** 2) <= r * r)
    if not np.any(step & ~maps.step_obstacle):
        return maps
    sdf = signed_distance(step, maps.resolution_m)
    return dataclasses.replace(
        maps, step_obstacle=step, sdf_step_m=sdf, grad_sdf_step=_gradient(sdf, maps.resolution_m)
    )


def attach_navigator(
    controller: Any,
    model: mujoco.MjModel,
    data: mujoco.MjData,
    goal_xy: tuple[float, float] | None,
    scene: TerrainScene | None = None,
    params: NavigatorParams | None = None,
) -> TerrainNavigator:
    """Gives a TerrainNavigator attached to the controller (hooks set, stages added)."""
    nav = TerrainNavigator(controller, model, data, goal_xy, scene, params)
    nav.attach()
    return nav


CommandSource = Callable[[RobotState], SteeringCommand]
