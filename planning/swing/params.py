"""SwingParams: limits, margins and the vertical gentleness family of the swing planner — a tuning guide.

Limits on the horizontal motion hold per axis of the heading frame (the body's yaw at planning time), as the seed
plans x and y separately; limits on the vertical motion hold on z. Every length is a foot *contact point* (the
bottom of the foot sphere), in meters.
"""

from __future__ import annotations

from dataclasses import dataclass, field


@dataclass(frozen=True, slots=True)
class VerticalLevel:
    """One vertical policy of the gentleness family: fractions of the z limits and a swing height.

    height_m: top of the swing above the higher of the lift-off and touchdown heights, m.
    accel_frac, velocity_frac: fractions of a_max_z_mps2 and of the up/down velocity limits.
    """

    height_m: float
    accel_frac: float
    velocity_frac: float


def _default_family() -> tuple[VerticalLevel, ...]:
    #            height   accel   velocity     (gentlest first; the most aggressive policy comes last, implicitly)
    # (accelerations 14, 20, 26, 32, 40 m/s²: the most aggressive policy alone uses the full a_max_z_mps2, 60 m/s²,
    # to rise over a box close ahead of the foot)
    return (
        VerticalLevel(0.06, 0.35 / 1.5, 0.50),
        VerticalLevel(0.08, 0.50 / 1.5, 0.60),
        VerticalLevel(0.11, 0.65 / 1.5, 0.75),
        VerticalLevel(0.15, 0.80 / 1.5, 0.85),
        VerticalLevel(0.20, 1.00 / 1.5, 1.00),
    )


@dataclass(frozen=True, slots=True)
class SwingParams:
    """Swing planner parameters (units in the names: m, s, m/s, m/s²)."""

    # Limits
    v_max_xy_mps: float = 4.0  # per heading axis
    a_max_xy_mps2: float = 80.0  # per heading axis
    v_max_up_mps: float = 2.0
    v_max_down_mps: float = 1.5
    a_max_z_mps2: float = 60.0
    max_swing_height_m: float = (
        0.30  # the most aggressive policy's top, above max(lift-off, touchdown) height
    )
    hip_clearance_m: float = 0.02  # the foot stays this far below (hip z − min leg length)
    apex_tolerance_m: float = (
        0.005  # a replan may lift the swing's apex by at most this over its first plan's
    )
    # ... unless terrain on the way (maps) stands above the lift-off→touchdown line: then the apex may rise to
    # obstacle_apex_m above the highest such terrain
    apex_free_over_obstacles: bool = True
    obstacle_apex_m: float = 0.08
    # On mapped terrain (not FlatGround) the apex stays within this above the highest ground on the straight way
    # (or the lift-off height); None: no such cap
    terrain_apex_m: float | None = 0.10

    # Vertical family, gentlest first; the most aggressive policy (full limits, max_swing_height_m) is appended.
    vertical_family: tuple[VerticalLevel, ...] = field(default_factory=_default_family)

    # Terrain
    clearance_margin_m: float = 0.02  # vertical margin the foot keeps over terrain away from its end points
    penetration_tol_m: float = 0.002  # deeper than this below the terrain is a collision
    obstacle_step_m: float = (
        0.01  # terrain this far above the lift-off→touchdown reference line is an obstacle
    )
    cliff_margin_m: float = 0.05  # horizontal margin to terrain above the foot; less is Cliff Scraping
    cliff_rings_m: tuple[float, ...] = (0.01, 0.02, 0.035, 0.05)  # radii probed (≥ the foot radius + margin)
    samples: int = 20  # time samples of a candidate trajectory in the detailed analysis
    knee_samples: int = 6  # interior samples at which knees are computed through the leg IK (when needed)
    knee_radius_m: float = 0.04  # knee-to-terrain margin
    knee_check_radius_m: float = 0.20  # knees are checked against a leg only when the foot comes this close
    # Rise first (steps up only: touchdown above the lift-off by more than rise_first_above_m): terrain on the
    # straight route (under the foot or a foot radius ahead) higher than the line from the lift-off height to the
    # touchdown by more than rise_first_above_m (the riser) holds the foot's x and y until the foot is
    # rise_first_margin_m above the highest ground on the route, closing in on it meanwhile (inf: never).
    rise_first_above_m: float = 0.03
    rise_first_margin_m: float = 0.01
    rise_first_top_m: float = 0.0  # the swing's top stays this far above the clearance height after a rise
    rise_first_gap_m: float = 0.02  # while rising, the foot's front closes in on the terrain up to this gap
    rise_first_v_up_mps: float = 2.0  # a rise-first swing rises at most this fast
    # a foot within this of the height it rises to has risen: its plan's top is that height, which it nears from
    # below, and a box read a millimetre higher on a later tick held the foot in place until its swing had no time
    # left to cross (clutter draw 899: 0.2 s held 0.3 mm under its clearance height, then the foot cut the box's edge)
    rise_first_done_m: float = 0.003
    # the foot waits at a place fixed from its lift-off place (True), not re-derived from the measured foot every
    # tick (False: a foot the leg carries past the wait point waits further on, closer to the riser)
    rise_first_anchored: bool = False
    # a leg that cannot lift its foot rise_first_margin_m over the terrain (its hip too low) waits until the foot
    # is as high as it reaches, when that clears the terrain by 5 mm (True), or does not wait (False)
    rise_first_within_reach: bool = False
    step_down_top_m: float = 0.10  # a step down (by more than rise_first_above_m) rises at most this much
    # A plan that collides with the terrain or scrapes an edge is planned again with its apex free of the swing's
    # first plan's (apex_tolerance_m: the foothold moved, or the map changed, since), and, still colliding, a swing
    # that is not a step up rises first over a box on its route (terrain on the straight route higher than both the
    # lift-off height and the line to the touchdown by more than rise_first_above_m); each kept when it ranks better.
    # False: neither (boxes on the way are the tiers' business)
    rise_over_boxes: bool = False
    # On mapped terrain, path samples within this (m) of the lift-off or the touchdown point see the ground there no
    # higher than that point, and no edge: the foot stands there. A swing ground dilated by the foot puts a noisy
    # floor's highest cell under the foot standing on it, and every candidate ranked a terrain collision at its
    # touchdown sample alone, the boxes on the way unjudged (clutter seed 190: the target 4 mm under its dilated
    # floor). Farther out the ground is judged as given (a box's edge beside the foothold may be under the foot
    # there). None: the ground as given everywhere.
    endpoint_zone_m: float | None = None
    # Lift-off clearance (any swing that is not a step up, on mapped terrain): ground within the first
    # liftoff_clear_run_m of the straight route from the lift-off place (the swing ground, already dilated by the
    # foot) standing above the lift-off height by more than rise_first_above_m (a box beside or just ahead of the
    # foot) makes the swing rise first, as a step up does: the foot's x and y wait where it is until it stands
    # liftoff_clear_margin_m above the highest ground on its route, then it moves on (a foot that moved this far
    # from its lift-off place is past the rule). 0: off (the first centimetres go sideways or forward at once, and
    # a foot lifting off beside a low box's edge catches it; see docs/terrain-notes.md, session 12).
    liftoff_clear_run_m: float = 0.0
    liftoff_clear_margin_m: float = 0.03

    # Other legs
    keepout_radius_m: float = 0.07  # lower legs closer than this collide (foot center to segment foot→knee)
    knee_keepout_m: float = 0.06  # knee to another lower leg
    swing_around_margin_m: float = 0.03  # waypoints sit this far beyond a keep-out area's corners
    xy_reach_tol_m: float = 0.002  # closer than this at touchdown counts as reaching the target

    # Selection
    preferred_policy: str = "Cubic"  # taken at once when it reaches Success
    preferred_bonus: float = 0.15  # subtracted from the preferred policy's undesirability
    miss_hysteresis_m: float = (
        0.01  # XY can't reach: keep last tick's policy unless another misses this much less
    )
    severity_bucket_m: float = 0.005  # collision severities closer than this count as equal ("if close")
    time_split_frac: float = 0.1  # combinations by time switch policy after this fraction of the swing

    # Loop
    replan_period_s: float = 0.003
    new_swing_gap_s: float = 0.05  # a leg not planned for this long starts a new swing (new lift-off height)
    min_replan_horizon_s: float = 0.015  # closer to touchdown than this, keep the last plan

    # Special policies
    late_descent_mps: float = 0.6  # late touchdown: descend at this speed until contact
    # ... faster by late_descent_gain_per_s times the height above the touchdown beyond late_descent_above_m (a
    # foot high above it after a step down), up to v_max_down_mps (0: a fixed speed; terrain-aware walking sets it)
    late_descent_gain_per_s: float = 0.0
    late_descent_above_m: float = 0.0
    trip_lift_m: float = 0.12  # normal trip: raise the foot this much above where it tripped
    trip_response_s: float = 0.15  # a trip's immediate response lasts this long
    recent_trip_s: float = 0.6  # after that, a trip this recent still elevates the foot
    knee_trip_speed_frac: float = 0.3  # knee trip: fraction of the xy limits used to move on slowly
    disentangle_margin_m: float = 0.05  # self-collision: lateral clearance sought from the other leg

    # Joint command
    foot_effective_mass_kg: float = 0.9  # lower-leg mass seen at the foot, for the feed-forward force

    # Event-driven selection (fields added last: recordings of older parameters unpickle by position): a replan
    # reuses the leg's last selection (the preferred policy in tier Success) and only rebuilds its trajectories from
    # the measured foot, skipping the tier analysis, while none of its inputs changed: the same terrain map object
    # and swing and stance legs, the stance feet within reuse_stance_tol_m and the target within reuse_target_tol_m
    # of where they were at the last full analysis, no rise-first hold or trip, no gentler vertical policy on time
    # again, the foot within reuse_foot_tol_m and reuse_foot_vel_tol_mps of where the last plan put it, and the last
    # full analysis at most reuse_selection_s ago (0: the full analysis every replan). Replays of recorded walks
    # (benchmarks.swing_replay, stairs, clutter, flat) select with these values what the full analysis selects.
    reuse_selection_s: float = 0.03
    reuse_foot_tol_m: float = 0.002
    reuse_foot_vel_tol_mps: float = 0.1
    reuse_stance_tol_m: float = 0.002
    reuse_target_tol_m: float = 0.0  # on stairs a target 2 mm off can meet the step's edge

    def __post_init__(self) -> None:
        for name in (
            "v_max_xy_mps",
            "a_max_xy_mps2",
            "v_max_up_mps",
            "v_max_down_mps",
            "a_max_z_mps2",
            "max_swing_height_m",
            "late_descent_mps",
            "replan_period_s",
        ):
            if not getattr(self, name) > 0.0:
                raise ValueError(f"SwingParams.{name}: must be > 0 (got {getattr(self, name)!r})")
        if self.samples < 4:
            raise ValueError(f"SwingParams.samples: needs at least 4 samples (got {self.samples})")
        for i, lv in enumerate(self.vertical_family):
            if not (0.0 < lv.accel_frac <= 1.0 and 0.0 < lv.velocity_frac <= 1.0 and lv.height_m >= 0.0):
                raise ValueError(
                    f"SwingParams.vertical_family[{i}]: fractions must lie in (0, 1] and the height be ≥ 0 ({lv})"
                )
