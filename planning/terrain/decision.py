"""The unified terrain pipeline's decisions: what the walk controller asks its terrain stack each step-plan tick.

One rule everywhere, nothing keyed on what a terrain is called or looks like:

- ``decide(view, world, last, params) -> TerrainDecision``: the body command along the body path (or the
  operator's), its speed capped by how far the last footholds had to move off their nominal places (the regions'
  room: a foothold sent far from where the capture-point selection wanted it means small regions or gaps, so the
  body slows), the gait (the slow gait below a speed share), the body height (standing, above the footholds'
  plane, lowered under an overhang) and pitch (the slope of that plane along the heading), and the swing
  constraint (the ground-height map dilated by the foot's radius: every swing clears the height profile and the
  edges along its way by the foot's radius, with the swing planner's own clearance on top);
- ``choose_footholds(view, path, world, memory, qp, params) -> FootholdDecision``: for each of the next K
  touchdowns a steppable region (the inset cells within search_m of the nominal foothold, the nearest region whose
  height is within reach of the leg's last foothold, distance plus w_height × the height change; the previous
  choice kept unless another is better by keep_m), a convex polygon of it grown around the nominal foothold, and
  the step QP with those polygons as hard constraints plus its reach, self-collision, CoP and balance rows.

Both are functions of typed inputs; the controller applies what they give. ``TerrainPipeline`` holds what lives
across ticks (perception, maps and regions, body path, the QP's warm start, the foothold memory) and is what the
controller calls.
"""

from __future__ import annotations

import dataclasses
import functools
import math
from dataclasses import dataclass, field
from typing import Any, Literal

import mujoco
import numpy as np
from numpy.typing import NDArray

from planning.geometry import clip_scalar
from planning.steps import SteeringCommand
from planning.steps.gait import get_gait
from planning.steps.select import Selection
from planning.steps.state import StepPath, rotate_yaw
from planning.swing.params import SwingParams
from planning.terrain.bodypath import BodyPath, BodyPathParams, plan_body_path, sweep_clearance
from planning.terrain.gridops import disk_filter
from planning.terrain.maps import TerrainMaps, maps_from_scene
from planning.terrain.memory import OverhangMemory
from planning.terrain.overlays import map_overlays, plan_overlays
from planning.terrain.perception import Perception, PerceptionParams
from planning.terrain.regions import (
    ConvexRegion,
    RegionParams,
    SteppableRegions,
    convex_around,
    segment_regions,
)
from planning.terrain.scenes import TerrainScene
from planning.terrain.steering import BarrierParams, StopParams, barrier_command, stop_short
from planning.terrain.stepqp import StepPlan, StepQP, StepQPParams, StepRequest


@dataclass(frozen=True)
class DecisionParams:
    """The unified pipeline's decisions (lengths m, times s, speeds m/s, angles rad).

    regions: segmentation (its foot radius is replaced by the robot's); search_m: regions are looked for within this
    of a nominal foothold; window_m: a foothold's polygon is grown from the region's cells within this of it;
    w_height: the distance (m) a metre of height change from the leg's last foothold costs in the region choice;
    max_rise_m: a region higher or lower than the leg's last foothold by more than this is out of reach; keep_m: the
    previous region of a touchdown is kept unless another costs this much less; inside_margin_m: when every
    nominal foothold lies this deep inside its polygon the step QP is not solved (its region rows would be
    inactive); freeze_s: a touchdown closer than this keeps its last foothold; late_jump_s, late_jump_m: a
    touchdown closer than late_jump_s keeps its last foothold when the step QP's new answer is not sound (a hard
    family softened, or not solved to tolerance), lies more than late_jump_m from it, and the kept one still lies
    on the slot's polygon (an answer with the reach box softened, or cut at OSQP's iteration limit, flipped a
    foot 0.3 m across the body 0.04 s before its touchdown, and back the next tick; the swing follows such a flip;
    None: off); flight_piece_s: a foot in the air due within this that keeps its region keeps the convex piece of
    it it was headed for too: its polygon is grown around its kept foothold, not the nominal one (see
    _piece_centre; 0: around the nominal, whose flicker across a box between two pieces of the floor moved a
    swing's target 0.4 m back and forth; for the whole swing, inf, the clutter family's no-step walks went 9 to 3
    of 50 but its falls 11 to 18); back_drop_frac: a walk to a goal goes down a descent backward (None: off, the
    default here; BACK_DROP_FRAC, 0.2, is the value measured, and WalkCommand.descend_backward, on by default, sets it). A descent edge is a
    fall in the ground along the body path of at least this share of the leg's length (thigh + shank) within
    back_edge_m (a riser, not a slope), the ground staying that much lower for back_beyond_m past it (a flight
    down, not the pit between two stones), on both of the feet's lines beside the path (read on the centre line,
    the slot between the mixed family's two columns of stones was an edge, and the body turned round before the
    stones). A descent edge within back_ahead_m ahead of the body's centre turns the
    body round in place to face against its path, and it walks backward until its centre is back_behind_m past the
    last descent edge (while walking backward an edge counts down to back_keep_frac of the fall and back_keep_m
    farther ahead: a fall measured at the threshold, or a path replanned during the turn, does not end it); then it
    turns to face its path again. Why: the knees point back, so a leg stepping down
    forward puts its shank over the nosing it steps off (the stairs family's tall risers fell on the descents);
    backward, the shank leans away from it. The turn is made only where the body can turn round in place: every circle of
    the footprint (turn_circles_x_m along the body, radius turn_circle_r_m: set by the pipeline to the barrier's
    footprint from the RobotModel) keeps turn_margin_m (the barrier's margin + 1 cm: it would stop the turn
    otherwise) from body obstacles at every heading on one of the two ways round (turn_room; the turn goes that
    way): between railings the body goes down forward as before. turn_clear_m: a turn round begins only with the descent edge at least this far ahead (the feet, turning,
    stay off it); back_level_frac: and only where the ground over back_behind_m behind the body's centre spans
    less than this share of the fall (level ground, not a flight); turn_timeout_s: a turn round not within turn_rad of its yaw by then is given up (the
    barrier, keeping the footprint off a body obstacle, can stop a turn midway), and the walk goes on forward with
    no other turn round (TerrainPipeline.may_turn); turn_rad: while a turn round
    is this far from its yaw, the body turns in place; max_speed_mps, min_speed_mps: the speed range; shift_slow_m: the speed falls from max to min as
    the largest move of a next foothold off its nominal grows to this (shift_counts_ahead False: a move forward
    along the heading does not count: a foot sent ahead of its nominal place, e.g. past a nosing it steps down
    over, asks the body to keep up, not to lag behind it); pace_m: and as the next touchdowns are moved back
    against the heading off their nominal places by this on average (the body is paced by its footholds: a stance pair held back by its regions is not overrun by the body, which would leave
    the body off the line between them and roll it over); hump_above_start: the swing time the gait must give
    (cadence) counts only ground that rises above the foot's own height as well as above its straight path (a
    foot stepping down past an edge at its own height needs no rise, and keeps the walk's short swings);
    count_step_rise: the swing time counts as well how far a next foothold lies above its foot where the two are on
    different regions (step_rise: a riser climbed, a box stepped onto; a slope is one region), so a swing up a
    riser has the time to rise over it (the 0.3 s swings of `climb` are too short for a 0.12 m riser);
    count_rise_behind: and, as much as that, how far a foot stands above a foot behind it on another region
    (rise_behind: a hind foot a riser below the front feet on the flight's top): on one tick whose next footholds
    all lay on their feet's treads, the stairs gait switched to `climb` and held it for gait_hold_s while a hind
    foot still had the last riser to climb, and its 0.16 s swing met the riser's face (4 of 4 stairs draws traced
    with a no-step touchdown, docs/terrain-notes.md, session 22);
    free_rise_m: where the walk is allowed faster (max_speed_mps) than the climb gaits stride (climb_top_speed), a
    rise (hump plus step rise) below this asks no more than base_swing_s (the swing's own lift clears it): on a
    plain slope the swing ground, dilated by the foot's radius, stands up to 29 mm above the straight swing
    (measured at 1.0 m/s on slope and rough), which alone picked `climb` there (0.05 m: under the swing's gentlest
    apex, 0.06 m); at allowances the climb gaits reach every
    rise counts (measured: the tolerance at 0.5 m/s too, the stairs quick spec 4 of 12 clean, against 8 of 12
    without it, main at f821bae; 5 fell); max_stride_m: the stride (the body's
    travel in a gait cycle) of the climb and slow gaits; fast_stride_reach_frac: the walk's own gait (ground where
    its swings suffice) strides as far as a foot placed that far ahead of its hip and lifted that far behind it,
    each at this share of the leg's full length with the hip at the standing height (Spot at 0.9: 0.57 m, 1.15
    m/s at the trot's 0.5 s cycle; max_stride_m where the view has no leg lengths);
    slow_gait, slow_gap_m, gap_behind_m, gap_ahead_m: the
    gait where a gap wider than slow_gap_m lies on the feet's lines from gap_behind_m behind the body to
    gap_ahead_m ahead (far enough ahead that the switch is made before the front feet reach it); slow_drop_m: the
    switch into the slow gait waits while a foot stands more than this above a foot ahead of it, along the way the
    body goes, on another region (rise_behind read the other way: a descent the hind feet have not finished; a walk
    already in the slow gait keeps it; None: no wait). A flight's foot lies within gap_ahead_m of the pit past it
    (the mixed family's 0.4 m floor), and the switch made mid-flight cut the body's speed from the climb gait's
    ~0.45 m/s to the crawl's 0.19 while a hind foot stepped down: its hip stayed behind the nosing, no foothold its
    shin cleared was in reach, and the shin came down on the nosing (the family's 13 hind lower-leg falls and 1
    upper-leg fall, each traced on main). 0.05 m (above the stones' height jitter between a platform and a
    stone): the mixed family 26 of 50 clean against 20, falls 19 to 6 (docs/terrain-notes.md, session 24);
    lookahead_m, yaw_gain,
    max_yaw_rate_rps, goal_gain, goal_tolerance_m: path following; yaw_lookahead_m: the body turns toward the path's
    yaw this far ahead of the path's point nearest the body (0: at that point; a path replanned from the body's pose
    starts at the body's yaw and turns to its heading over its first 0.3 m, so with 0 a path replanned every tick,
    as one grazing a body obstacle is, asks no turn at all and the body crabs along it at its old yaw), applied only
    while the path's sweep comes within yaw_near_m of a body obstacle (None: always). Off (0): on the clutter family
    (50 draws, main 22 clean) 0.3 m always gave 19 clean (the trunk falls 5 to 2, new rolls in the slow gaits at the
    faster turns) and 0.3 m within 0.05 m gave 16 (docs/terrain-notes.md, session 11); max_pitch_rad, max_pitch_rate_rps, pitch_gain: body pitch (the footholds' plane's
    slope × pitch_gain);
    posture: "plane": the body's height offset and pitch from the footholds' plane (its height at the body, its
    slope along the heading, as above); "hips": from the support's heights as the hips see them (hips_plane: the
    support heights fitted against the hips' offsets along the body, the pitch the one at which every hip stands
    as high above its own support as the others, on a least-squares average, the offset the fit's height at the
    body's centre): on a descent the front feet reach ahead of their hips and the hind feet trail behind theirs,
    so the footholds' plane is shallower than the drop between the hips' supports and the high (hind) pair's hips
    sit lower above their treads than the low pair's; the same rule on flat ground (no slope: the same height);
    "pairs": as "hips" with each pair's (the front hips', the hind hips') highest support instead of the
    least-squares line (hips_pairs: the pitch at which the most folded leg of each pair stands as high above its
    support as the other pair's; a hind foot swinging down to the next tread does not lower the hind hips while
    the other hind foot still stands on the tread above). Off ("plane"): on the stairs quick spec (main 8 of 12
    clean) "hips" gave 3 (the descent falls 2 to 8, hind legs) and "pairs" 2; on the mixed quick spec (main 7)
    "hips" gave 5 (docs/terrain-notes.md, session 12);
    plane_touchdowns: the posture's supports (the footholds' plane, hips_plane, hips_pairs) count a swinging leg's
    chosen touchdown (False: a swinging leg's last stance height instead: the pitch and height move with the
    touchdowns, not toward a touchdown while its foot is still in the air and the other legs carry the body). On
    (True): False gave 6 of 12 on the stairs quick spec (main 8) and 4 of 12 on the mixed quick spec (main 7);
    max_height_offset_m: the body's offset from the footholds' plane above the mean contact height at most this;
    level_extension_frac, level_span_m: on level ground the body walks with its hips this share of the leg's full
    length (thigh + shank) above the feet's centres, never lower than the standing height (level_height); the
    more the stance feet and the chosen touchdowns differ in height, the nearer the standing height, reached at a
    span of level_span_m (a riser, the platform: the climb's and descent's reach rules assume the standing
    height). A taller stance stands the shins steeper: over a box's or the platform's edge behind a foothold they
    pass higher. 0.81 (Spot: 0.570 m against 0.52 m standing; None: the standing height everywhere) with the swing's
    rise_first_done_m measured the clutter family 30 of 50 clean against 26 (falls 24 to 11, no-step touchdowns 5
    to 9), stairs 29 against 27 (docs/terrain-notes.md, session 18); ungated (0.04 and 0.07 m above the standing
    height everywhere) the stairs got worse (3 of 20 against 7 at 0.07 m);
    min_height_m, body_top_m, head_margin_m, crouch_ahead_m, ceiling_above_m: under an overhang within crouch_ahead_m
    the body height is lowered to keep body_top_m + head_margin_m under it, down to min_height_m (overhangs at
    least ceiling_above_m above the ground count); swing_margin_m: the swing ground is dilated by the foot radius
    plus this; path_rate_hz: body path replans; path_worse_m: between them, the path is replanned at once when the
    rest of it ahead of the body sweeps into a body obstacle deeper than this below the clearance it had when planned
    (a new obstacle seen; None: whenever the rest sweeps below 0, so a path that grazes an obstacle from the start
    is replanned every tick, each replan starting at the body's yaw; see path_holds). Off (None): 0.02 gave 16 of
    the clutter family's 50 clean against main's 22 (23 falls against 19); shin_clear_m: a foothold keeps the ground at least this far from
    its shin's axis (knee from the leg's lengths, the hip where the body will be at touchdown), looking at the
    ground from shin_behind_m behind the foot along the heading to a few cm ahead, where it stands more than
    shin_edge_m above the foothold (an edge the foot stepped down from, a box behind it); a foothold that does not
    is moved along the heading, within shin_search_m and its polygon, to the nearest place that does (a
    half-plane added to its polygon); reach_frac: a foothold lies no farther from its hip at touchdown (in the
    ground plane) than the leg at this share of its full length (thigh + shank) reaches with the hip at the
    standing height: regions beyond are not chosen, and a polygon reaching beyond is bounded along the heading
    the same way; trail_reach_frac: the body goes no faster than lets every stance foot lift off (at its planned
    liftoff) before its hip, moving on, leaves it farther than this share of the leg's full length (along the
    heading and up, the hip at the body's height and pitch targets): a foot held down long (a gait switch, a
    late swing elsewhere) or a tread below is not left trailing on a straight leg (the speed may fall to 0 until
    it lifts); height_reach_frac: the body height is at most the one at which every stance foot lies within this
    share of the leg's full length of its hip (along the heading and up, the hips placed by the pitch target): a
    hind foot a tread below keeps the body down instead of hanging from a straight leg (not below min_height_m: a
    stance foot left far behind or ahead bounded the height to the ground, and the body sank onto the boxes,
    clutter draw 202); touchdown_reach_frac: the
    body height is also at most the one at which every swinging leg's chosen touchdown lies within this share of
    the leg's full length of its hip (the same geometry; not below min_height_m): a front foot stepping down a
    riser is not sent to a tread its straight leg only reaches after the body has come down (steep stairs: the
    leg straight 1 cm above the tread, its swing thrown forward and up, the touchdown 0.2 s late; None: off, as
    0.95 measured worse: the whole body comes down, the hind hips with it, and a hind shin meets the nosing it
    steps past); lost_hold_m: a next touchdown whose previous foothold lies on no region in this map (the
    segmentation lost the cell for a moment: a re-segmentation, a cell seen anew) while the ground there is within
    this of the foothold's height keeps that foothold: the ground did not move, and a foot committed to a tread is
    not sent to the floor beside it;
    hold_region_m2: the slow gait's liftoffs wait for static balance (TerrainDecision.support_hold, the controller's
    SupportShiftParams.hold for the tick) while a foot in stance stands on a region smaller than this (stepping
    stones: a stance foot near a stone's edge unloads and slides off when a liftoff leaves the centre of mass
    outside the other three feet), and not on broad ground (the floor among boxes, where a held liftoff shortens
    the swing over a box) (None: off). At 0.3 m² (Spot's stones are 0.09–0.23 m², a tread of a 1.2 m flight
    0.3–0.5 m², walked in a climb gait the hold does not touch): the stones family 43 of 50 clean against 38 (falls
    7 to 1), the clutter family 29 as without it (the same 50 walks), the mixed family 25 against 22, stairs 27 and rough
    50 as without it (docs/terrain-notes.md, session 14);
    gap_dip_m: a run without a region counts as a gap (gap_ahead) unless it only goes from one height to
    another (its two ends differ by more than this and its ground stays within this of the range between them: a
    riser's edge band), or, at the line's end, its ground stays above this below its one end (None: every run
    counts); a pit, the space between stones, the floor around a box (both ends at one height) stay gaps;
    gap_flight_steps: with gap_dip_m, a run from one height to another is no gap only on a line whose ground is a
    flight: it goes one way only (never back by more than gap_dip_m) through at least this many steps (height
    changes of more than gap_dip_m, each its edge cells together), read on its observed cells only (the treads of a
    climb above the sensor are unseen, their filled heights low): the floor onto a box and off it again, or one
    box's edge alone, stay gaps (None: any line);
    own_side_m: a region's cell is chosen for a foothold only where it lies at least the foot's radius plus this on
    the leg's own side of the body's centre line (the body where the path puts it at touchdown; None: no such
    bound): a left foot is not sent onto a right stone, where the legs cross and one's shin meets the other
    stone or leg (stones draws 254 and 167: a front left foot's own stone 1-4 mm farther than reach_frac from
    its hip, the right stone of the row 1-4 mm nearer, chosen, both lower legs then on the right stone, a fall);
    shin_rule: "line" (the rule above), "segment": the ground read along the shin itself instead of the line along
    the heading (shin_segment_clearance: the segment from the foot to the knee at the stance pose, the knee from the leg's
    abducted plane, the hip where the body will be at touchdown, the ground within the shin's radius of each
    point, above the ground's own plane at the foot): a foothold's shin then clears the ground by shin_margin_m
    beyond the shin's radius (shin_clear_m, shin_behind_m and shin_edge_m are the line rule's); the search along
    the heading is the same (shin_search_m); "both": a foothold passes both. Off ("line"): "both" gave 27 of the
    clutter family's 50 clean against main's 29 (5 gains, 7 losses; docs/terrain-notes.md, session 13);
    shin_hold: when no place of a next touchdown's polygon along the heading within shin_search_m clears the shin
    (leg_bounds_found: some places within reach, none clearing) and a foothold was chosen on a region for this
    touchdown before where the shin cleared (FootholdMemory.shin_ok), a foot in the air keeps that choice instead
    of taking the place of most clearance (False, a foot in stance, or no such choice: that place, which may still
    meet the edge): a nominal that drifts, late in a swing or at a liftoff, past a
    box or onto the tread below, where the shin would meet the edge it steps past, leaves the foot where it was
    going;
    shin_regions: the shin test as a region filter (0 or 1: off): a next touchdown's region none of whose places along
    the heading within shin_search_m clears the shin (leg_bounds_found: some within reach, none clearing) is
    rejected like a region out of reach, and the region choice is made again without it, up to this many regions
    tried in all (shin_region: the landing above a tread, the floor before a box); when none of them has a
    clearing place the first region stands and its place of most clearance is taken (the behaviour with 0). The
    filter acts while the foot is in stance: in the air the foot keeps the region it lifted off for (a region
    switched late in a swing sends a foot already past a nosing back onto it);
    shin_region_cost_m: the shin test in the region cost (None: off): when no place of a next touchdown's chosen
    polygon along the heading clears the shin (leg_bounds_found), the foothold is chosen again over every inset
    cell within shin_region_search_m of the nominal foothold and within reach (the height and side rules of
    choose_region), each costing its distance + w_height × height change, plus this (m) where the leg's shin
    would not clear (leg_clearance with the hip at touchdown, the cells read with shin_region_rule;
    shin_cell_cost) and on every cell of the chosen region (its places do not clear; shin_region_same False):
    when the cell of least cost clears, the foothold is held there (shin_choice, shin_cost_region): a low box's or
    the platform's top behind a nominal past it, whose long step puts the shin on the edge; none clearing within
    this cost, nothing changes. The choice made before is kept while it clears and costs at most keep_m more; in
    the air a choice made where the shin cleared stands (no new choice late in a swing). Where the chosen polygon
    has a clearing place (flat ground, most footholds) nothing more is evaluated and nothing changes; active
    also on a descent (a front foot held on the landing while its hip is behind the nosing). Off: at 0.5 the
    clutter family measured 29 of 50 clean as main (3 gains: the platform draws 697, 999 and 699; 3 losses) and
    the stairs quick spec 1 of 12 against 7 (a descending foot held a tread back or two treads down;
    docs/terrain-notes.md, session 14);
    shin_region_search_m: shin_region_cost_m's search radius around the nominal foothold (m; the floor before a
    box lies up to ~0.42 m behind a nominal past it); shin_region_rule: the shin rule (shin_rule's values) the
    cells are read with: "both" (line and segment), as a search over cells finds the line rule's blind spot, a
    place beside a box whose heading line just misses its corner (clutter draw 762 with "line": a front foot
    held 6 cm beside a box); shin_region_same: the chosen region's own clearing cells count too (the floor
    before or beside a box; with "line" cells this measured 25 of the clutter family's 50 against main's 29)."""

    regions: RegionParams = field(default_factory=lambda: RegionParams(max_planes=8))
    search_m: float = 0.30
    window_m: float = 0.45
    w_height: float = 0.3
    max_rise_m: float = 0.25
    keep_m: float = 0.05
    inside_margin_m: float = 0.02
    freeze_s: float = 0.04
    late_jump_s: float | None = 0.2
    late_jump_m: float = 0.1
    back_drop_frac: float | None = None
    back_edge_m: float = 0.09
    back_beyond_m: float = 0.4
    back_ahead_m: float = 0.7
    back_behind_m: float = 0.6
    back_keep_frac: float = 0.75
    turn_clear_m: float = 0.45
    back_level_frac: float = 0.5
    turn_timeout_s: float = 20.0
    back_keep_m: float = 0.3
    turn_rad: float = 0.4
    turn_circles_x_m: tuple[float, ...] = (-0.3, 0.0, 0.3)
    turn_circle_r_m: float = 0.17
    turn_margin_m: float = 0.06
    flight_piece_s: float = 0.2
    max_speed_mps: float = 0.5
    min_speed_mps: float = 0.2
    shift_slow_m: float = 0.15
    shift_counts_ahead: bool = False
    hump_above_start: bool = True
    pace_m: float = 0.10
    slow_gait: str | None = "crawl"
    slow_gap_m: float = 0.25
    gap_behind_m: float = 0.3
    gap_ahead_m: float = 1.3
    climb_gaits: tuple[str, ...] = ("climb", "stairs")
    free_rise_m: float = 0.05
    max_stride_m: float = 0.3
    fast_stride_reach_frac: float = 0.9
    base_swing_s: float = 0.2
    rise_speed_mps: float = 0.75
    gait_hold_s: float = 2.0
    lookahead_m: float = 0.45
    yaw_gain: float = 1.2
    yaw_lookahead_m: float = 0.0
    yaw_near_m: float | None = 0.05
    max_yaw_rate_rps: float = 0.5
    goal_gain: float = 0.8
    goal_tolerance_m: float = 0.06
    max_pitch_rad: float = 0.6
    max_pitch_rate_rps: float = 0.6
    pitch_gain: float = 1.0
    posture: Literal["plane", "hips", "pairs"] = "plane"
    plane_touchdowns: bool = True
    max_height_offset_m: float = 0.15
    level_extension_frac: float | None = 0.81
    level_span_m: float = 0.10
    min_height_m: float = 0.38
    body_top_m: float = 0.10
    head_margin_m: float = 0.04
    crouch_ahead_m: float = 0.7
    ceiling_above_m: float = 0.30
    swing_margin_m: float = 0.01
    path_rate_hz: float = 2.0
    path_worse_m: float | None = None
    shin_clear_m: float = 0.10
    shin_search_m: float = 0.30
    shin_behind_m: float = 0.40
    shin_edge_m: float = 0.03
    shin_rule: str = "line"
    shin_margin_m: float = 0.04
    hold_region_m2: float | None = 0.3
    shin_hold: bool = False
    shin_regions: int = 0
    shin_region_cost_m: float | None = None
    shin_region_search_m: float = 0.45
    shin_region_rule: str = "both"
    shin_region_same: bool = False
    reach_frac: float = 0.9
    trail_reach_frac: float = 0.95
    height_reach_frac: float = 0.9
    touchdown_reach_frac: float | None = None
    lost_hold_m: float = 0.03
    gap_dip_m: float | None = 0.05
    gap_flight_steps: int | None = 2
    count_step_rise: bool = True
    count_rise_behind: bool = True
    slow_drop_m: float | None = 0.05
    own_side_m: float | None = 0.0


# ---- typed inputs and outputs ----------------------------------------------------------------------------------


@dataclass(frozen=True, eq=False)
class TerrainView:
    """What the decisions read of the controller and the robot (world frame, m, rad, s).

    t_s: now; p_world_body (3,), yaw; p_world_foot (4, 3): foot centres; stance (4,): feet down; z_contact: the
    mean contact height the controller holds its body height above; gait: the gait walked; operator:
    the operator's command (used when there is no goal); goal (2,) or None; pitch_rad: the pitch target now;
    foot_radius_m, standing_height_m, p_body_hip (4, 2), l_upper_m, l_lower_m (thigh and shank; 0: no shin rule),
    abd_offset_m (4,): each leg's plane's lateral offset from its abduction axis (left +; None: 0), shin_radius_m:
    the lower leg's collision radius: from the RobotModel; dt_s: the step-plan period."""

    t_s: float
    p_world_body: NDArray[np.float64]
    yaw: float
    p_world_foot: NDArray[np.float64]
    v_world_foot: NDArray[np.float64]
    stance: NDArray[np.bool_]
    z_contact: float
    gait: str
    gait_since_s: float
    fast_gait: str
    operator: SteeringCommand
    goal: NDArray[np.float64] | None
    pitch_rad: float
    height_m: float
    foot_radius_m: float
    standing_height_m: float
    p_body_hip: NDArray[np.float64]
    dt_s: float
    l_upper_m: float = 0.0
    l_lower_m: float = 0.0
    abd_offset_m: NDArray[np.float64] | None = None
    shin_radius_m: float = 0.0


@dataclass(frozen=True, eq=False)
class HeightGrid:
    """A height field (m) on a grid like the maps' ([ix, iy], cell centres at origin + index × resolution)."""

    origin_xy: tuple[float, float]
    resolution_m: float
    height: NDArray[np.float64]

    def __call__(self, x: Any, y: Any) -> Any:
        """Gives the height (m) at world (x, y), the nearest cell's (border cells beyond the grid)."""
        h = self.height
        nx, ny = h.shape
        # np.clip's values through minimum/maximum (without its dispatch cost), one flat gather
        ix = np.rint((np.asarray(x, dtype=np.float64) - self.origin_xy[0]) / self.resolution_m)
        iy = np.rint((np.asarray(y, dtype=np.float64) - self.origin_xy[1]) / self.resolution_m)
        ix = np.minimum(np.maximum(ix, 0.0), nx - 1).astype(np.intp)
        iy = np.minimum(np.maximum(iy, 0.0), ny - 1).astype(np.intp)
        v = h.ravel().take(ix * ny + iy) if h.flags.c_contiguous else h[ix, iy]
        return v.item() if v.ndim == 0 else v


@dataclass(frozen=True, eq=False)
class TerrainWorld:
    """What the pipeline knows of the terrain at one moment: the maps, their regions, the swing ground, the body
    path (None: none yet or steered)."""

    maps: TerrainMaps
    regions: SteppableRegions
    swing_ground: HeightGrid
    path: BodyPath | None
    # the lowest overhang underside (world z, m) ever seen over each cell (inf: none): the sensor loses sight of a
    # table's top once the body is under it (memory.OverhangMemory); None: the maps' own clearance only
    overhangs: HeightGrid | None = None


@dataclass(frozen=True, eq=False)
class FootholdMemory:
    """Per leg: the touchdown time (s, nan: none) of its next touchdown as last decided, the foothold chosen for it
    (3,), the height (m) of its last stance foothold, whether that foothold was chosen on a region (None: all
    were), and whether it was chosen where the shin clears the ground (leg_bounds_found; None: not known)."""

    t_touchdown: NDArray[np.float64]
    p_chosen: NDArray[np.float64]
    z_stance: NDArray[np.float64]
    on_region: NDArray[np.bool_] | None = None
    shin_ok: NDArray[np.bool_] | None = None

    @staticmethod
    def empty() -> FootholdMemory:
        return FootholdMemory(np.full(4, np.nan), np.full((4, 3), np.nan), np.full(4, np.nan))


@dataclass(frozen=True, eq=False)
class FootholdDecision:
    """The footholds decided for a step path: p_world_touchdown (N, 3) in the path's order; regions: the polygon
    of each QP slot (None: free); plan: the step QP's answer (None: not solved); max_shift_m: the largest move of a
    next touchdown off its nominal; memory: what the next decision keeps; back_m: how far the next touchdowns
    were moved back against the heading off their nominal places, on average over the legs (moves forward count
    0); t_liftoff (4,): each stance leg's planned liftoff (s; nan: in the air or none planned); late_holds: next
    touchdowns that kept their foothold against a late jump of the step QP's answer (DecisionParams.late_jump_s)."""

    p_world_touchdown: NDArray[np.float64]
    regions: tuple[ConvexRegion | None, ...]
    plan: StepPlan | None
    max_shift_m: float
    memory: FootholdMemory
    back_m: float = 0.0
    t_liftoff: NDArray[np.float64] | None = None
    late_holds: int = 0


Facing = Literal["forward", "back", "round"]


@dataclass(frozen=True, eq=False)
class TerrainDecision:
    """What the controller applies this tick: the body command (body frame), the gait, the body height above the
    mean contact height and the pitch target (positive nose down), the ground the swings clear, the speed cap it
    came from, and whether the slow gait's liftoffs wait for static balance (support_hold: the controller's
    SupportShiftParams.hold for this tick, see DecisionParams.hold_region_m2), and how the body faces along its path
    (next_facing: "back" walking down a descent backward, "round" turning to face its path again); slow_wait: the
    slow gait was asked for by a gap ahead and waits for a descent's hind feet (DecisionParams.slow_drop_m)."""

    command: SteeringCommand
    gait: str
    body_height_m: float
    body_pitch_rad: float
    swing_ground: HeightGrid
    speed_cap_mps: float
    support_hold: bool = False
    facing: Facing = "forward"
    slow_wait: bool = False


# ---- the decisions ---------------------------------------------------------------------------------------------


def decide(
    view: TerrainView,
    world: TerrainWorld,
    last: FootholdDecision | None,
    params: DecisionParams,
    facing: Facing = "forward",
    may_turn: bool = True,
) -> TerrainDecision:
    """Gives the body command, gait, body height and pitch and the swing ground (see the module docstring); facing:
    how the body faced along its path on the tick before (TerrainDecision.facing; see next_facing); may_turn False:
    forward (a turn round given up, DecisionParams.turn_timeout_s)."""
    p = params
    if may_turn and view.goal is not None and world.path is not None and world.path.length_m > 1e-6:
        facing = next_facing(view, world.maps, world.path, facing, p)
    else:
        facing = "forward"
    shift = 0.0 if last is None else last.max_shift_m
    back = 0.0 if last is None else last.back_m
    frac = float(
        clip_scalar(min(1.0 - shift / max(p.shift_slow_m, 1e-9), 1.0 - back / max(p.pace_m, 1e-9)), 0.0, 1.0)
    )
    lo = p.min_speed_mps / max(p.max_speed_mps, 1e-9)
    share = lo + (1.0 - lo) * frac
    cap = p.max_speed_mps * share
    back = facing == "back"
    gait, slow_wait = _cadence(view, world, last, p, back)
    cap = min(cap, stride_m(view, gait, p) / get_gait(gait).cycle_s, trail_speed(view, last, p, back))
    command = (
        follow_path(view, world.path, cap, p, facing, world.maps)
        if view.goal is not None
        else capped(view.operator, cap, p)
    )
    td = p.plane_touchdowns
    if p.posture in ("hips", "pairs"):
        offset, sin_pitch = hips_plane(view, last, td) if p.posture == "hips" else hips_pairs(view, last, td)
        pitch_target = math.asin(float(clip_scalar(p.pitch_gain * sin_pitch, -1.0, 1.0)))
        pitch_target = float(clip_scalar(pitch_target, -p.max_pitch_rad, p.max_pitch_rad))
    else:
        offset, slope = footholds_plane(view, last, td)
        pitch_target = float(clip_scalar(-math.atan(p.pitch_gain * slope), -p.max_pitch_rad, p.max_pitch_rad))
    step = p.max_pitch_rate_rps * view.dt_s
    pitch = view.pitch_rad + float(clip_scalar(pitch_target - view.pitch_rad, -step, step))
    height = level_height(view, last, p) + float(
        clip_scalar(offset, -p.max_height_offset_m, p.max_height_offset_m)
    )
    height = min(height, crouch_height(view, world.maps, p, world.overhangs), reach_height(view, pitch, p))
    if p.touchdown_reach_frac is not None and last is not None:
        height = min(height, touchdown_reach_height(view, last.memory.p_chosen, pitch, p))
    hold = p.hold_region_m2 is not None and on_small_regions(view, world, p.hold_region_m2)
    return TerrainDecision(command, gait, height, pitch, world.swing_ground, cap, hold, facing, slow_wait)


def level_height(view: TerrainView, last: FootholdDecision | None, p: DecisionParams) -> float:
    """Gives the body height (m, above the mean contact height) before the footholds' plane, the ceilings and
    the reach bound it: on level ground, the height at which the hips stand level_extension_frac of the leg's full
    length above the feet's centres (the shins steeper, clearing a low box's edge or a stone's behind the foot by
    more), never below the standing height; the more the feet in stance and the chosen touchdowns differ in height
    (a step, a riser, the platform), the nearer the standing height, reached at level_span_m (the reach rules of a
    climb and a descent assume it)."""
    if p.level_extension_frac is None or view.l_upper_m <= 0.0:
        return view.standing_height_m
    tall = view.foot_radius_m + p.level_extension_frac * (view.l_upper_m + view.l_lower_m)
    if tall <= view.standing_height_m:
        return view.standing_height_m
    z = view.p_world_foot[view.stance, 2] - view.foot_radius_m
    if last is not None:
        chosen = last.memory.p_chosen[~view.stance, 2]
        z = np.concatenate([z, chosen[np.isfinite(chosen)]])
    span = float(np.ptp(z)) if z.size else 0.0
    share = float(clip_scalar(1.0 - span / max(p.level_span_m, 1e-9), 0.0, 1.0))
    return view.standing_height_m + share * (tall - view.standing_height_m)


def on_small_regions(view: TerrainView, world: TerrainWorld, area_m2: float) -> bool:
    """Whether a foot in stance stands on a steppable region smaller than area_m2 (a stepping stone, not the floor
    or a tread; a cell of no region counts nothing)."""
    regions = world.regions
    res = regions.resolution_m
    nx, ny = regions.labels.shape
    for leg in np.flatnonzero(view.stance).tolist():
        ix = int(round((float(view.p_world_foot[leg, 0]) - regions.origin_xy[0]) / res))
        iy = int(round((float(view.p_world_foot[leg, 1]) - regions.origin_xy[1]) / res))
        if 0 <= ix < nx and 0 <= iy < ny:
            label = int(regions.labels[ix, iy])
            if label > 0 and float(regions.area_m2[label]) < area_m2:
                return True
    return False


def stride_m(view: TerrainView, gait: str, p: DecisionParams) -> float:
    """Gives the longest stride (m a gait cycle) of the gait: the leg's reach (fast_stride_reach_frac) for the walk's
    own gait, max_stride_m for the others (and where the view has no leg lengths)."""
    if gait != view.fast_gait or view.l_upper_m <= 0.0:
        return p.max_stride_m
    reach = p.fast_stride_reach_frac * (view.l_upper_m + view.l_lower_m)
    return max(2.0 * math.sqrt(max(reach**2 - view.standing_height_m**2, 0.0)), p.max_stride_m)


def climb_top_speed(view: TerrainView, p: DecisionParams) -> float:
    """Gives the fastest (m/s) any of the climb gaits strides (stride_m over its cycle; 0: no climb gaits)."""
    return max((stride_m(view, g, p) / get_gait(g).cycle_s for g in p.climb_gaits), default=0.0)


def trail_speed(
    view: TerrainView, last: FootholdDecision | None, p: DecisionParams, back: bool = False
) -> float:
    """Gives the highest body speed (m/s) at which every stance foot still lies within trail_reach_frac of the
    leg's full length of its hip at the foot's planned liftoff, the hip moving on along the heading (back: against
    it) at the body's height and pitch targets (inf: no leg lengths or no liftoff planned)."""
    if last is None or last.t_liftoff is None or view.l_upper_m <= 0.0:
        return np.inf
    length = p.trail_reach_frac * (view.l_upper_m + view.l_lower_m)
    sign = -1.0 if back else 1.0  # along the way the body goes: backward down a descent (back_drop_frac)
    u = sign * np.array([math.cos(view.yaw), math.sin(view.yaw)])
    x_hip = view.p_body_hip[:, 0]
    s_hip = float(view.p_world_body[:2] @ u) + sign * x_hip * math.cos(view.pitch_rad)
    z_hip = view.z_contact + view.height_m - math.sin(view.pitch_rad) * x_hip
    trail = s_hip - view.p_world_foot[:, :2] @ u
    dz = z_hip - view.p_world_foot[:, 2]
    room = np.sqrt(np.maximum(length**2 - dz**2, 0.0)) - trail
    remain = last.t_liftoff - view.t_s
    use = view.stance & np.isfinite(remain)
    if not use.any():
        return np.inf
    return float(np.min(np.maximum(room[use], 0.0) / np.maximum(remain[use], view.dt_s)))


def cadence(
    view: TerrainView,
    world: TerrainWorld,
    last: FootholdDecision | None,
    p: DecisionParams,
    back: bool = False,
) -> str:
    """Gives the gait: the slow gait where a gap longer than slow_gap_m lies on the feet's lines ahead (gap_ahead),
    once no foot stands more than slow_drop_m above a foot ahead of it on another region (a descent's hind feet);
    else the first of the walk's own gait and then climb_gaits whose swing lasts long enough to rise over the
    ground above the straight line of the next swings (swing_hump; base_swing_s + rise / rise_speed_mps, a rise
    below free_rise_m counting 0 where the allowance is above climb_top_speed) and up to the next footholds, or to
    the feet ahead along its way (step_rise, rise_behind, way_yaw; back: the body walks backward); a gait switch is
    held for gait_hold_s."""
    return _cadence(view, world, last, p, back)[0]


def _cadence(
    view: TerrainView,
    world: TerrainWorld,
    last: FootholdDecision | None,
    p: DecisionParams,
    back: bool = False,
) -> tuple[str, bool]:
    """cadence's gait, and whether the slow gait waited for a descent's hind feet on this tick (slow_drop_m)."""
    if view.t_s - view.gait_since_s < p.gait_hold_s:
        return view.gait, False
    waited = False
    way: float | None = None  # the way the body goes (way_yaw), read once where a rule needs it
    if p.slow_gait is not None and gap_ahead(view, world, p) > p.slow_gap_m:
        if p.slow_drop_m is None or view.gait == p.slow_gait:
            return p.slow_gait, False
        way = way_yaw(view, world, p, back)
        if rise_behind(view, world, last, way + math.pi) <= p.slow_drop_m:  # no foot above one ahead of it
            return p.slow_gait, False
        waited = True
    rise = swing_hump(view, world, last, p.hump_above_start)
    if p.count_step_rise:
        up = step_rise(view, world, last)
        if p.count_rise_behind:
            way = way_yaw(view, world, p, back) if way is None else way
            up = max(up, rise_behind(view, world, last, way))
        rise += up
    if rise < p.free_rise_m and p.max_speed_mps > climb_top_speed(view, p):
        rise = 0.0
    need = p.base_swing_s + rise / p.rise_speed_mps
    for name in (view.fast_gait, *p.climb_gaits):
        if get_gait(name).swing_s >= need - 1e-9:
            return name, waited
    return (p.climb_gaits[-1] if p.climb_gaits else view.fast_gait), waited


def step_rise(view: TerrainView, world: TerrainWorld, last: FootholdDecision | None) -> float:
    """Gives the most (m) a chosen next foothold lies above its foot where the two stand on different regions (a
    riser's tread above, a box's or a stone's top): the height a swing climbs besides its hump; 0 on one region
    (a slope is one plane) or stepping down."""
    if last is None:
        return 0.0
    chosen = last.memory.p_chosen
    regions = world.regions
    most = 0.0
    for leg in range(4):
        b = chosen[leg]
        if not np.all(np.isfinite(b)):
            continue
        a = view.p_world_foot[leg]
        up = float(b[2]) - (float(a[2]) - view.foot_radius_m)
        if up > most and regions.label_at(float(a[0]), float(a[1])) != regions.label_at(
            float(b[0]), float(b[1])
        ):
            most = up
    return most


def way_yaw(view: TerrainView, world: TerrainWorld, p: DecisionParams, back: bool = False) -> float:
    """Gives the way (rad) the body goes: along its path (travel_yaw) to a goal, else its heading (reversed walking
    backward: back)."""
    if view.goal is not None and world.path is not None and world.path.length_m > 1e-6:
        return travel_yaw(view, world.path, p)
    return view.yaw + (math.pi if back else 0.0)


def rise_behind(
    view: TerrainView, world: TerrainWorld, last: FootholdDecision | None, way_yaw: float
) -> float:
    """Gives the most (m) a foot stands above a foot behind it along the way the body goes (way_yaw, rad: its
    path's way, whichever way it faces) where the two stand on different regions: what the feet behind have
    still to climb (a hind foot a riser below the front feet on a flight's top), besides their next footholds.
    Each foot where it stands, or a foot in the air at the height of its last stance foothold (support_points);
    0 on one region (a slope is one plane), or with every foot at least as high as those ahead (a descent,
    facing down it or walking backward; a turn round at the foot of a flight, the path leading away from it)."""
    pts = support_points(view, last, touchdowns=False)
    u = np.array([math.cos(way_yaw), math.sin(way_yaw)])
    along = pts[:, :2] @ u
    regions = world.regions
    labels = [regions.label_at(float(x), float(y)) for x, y in pts[:, :2].tolist()]
    most = 0.0
    for i in range(4):
        for j in range(4):
            up = float(pts[i, 2] - pts[j, 2])
            if up > most and along[i] > along[j] and labels[i] != labels[j]:
                most = up
    return most


def swing_hump(
    view: TerrainView, world: TerrainWorld, last: FootholdDecision | None, hump_above_start: bool = False
) -> float:
    """Gives how far (m) the ground (the swing ground) rises above the straight line from each foot to its chosen
    next foothold, the most over the legs: what a swing must rise over beyond the step's own height change (a
    riser's nosing, a box's edge; about 0 on a slope or over a gap)."""
    if last is None:
        return 0.0
    chosen = last.memory.p_chosen
    ok = np.all(np.isfinite(chosen), axis=1)
    if not ok.any():
        return 0.0
    a = view.p_world_foot[ok].copy()
    a[:, 2] -= view.foot_radius_m
    b = chosen[ok]
    u = np.linspace(0.1, 0.9, 9)[None, :, None]
    pts = a[:, None, :] * (1.0 - u) + b[:, None, :] * u
    g = np.asarray(world.swing_ground(pts[..., 0], pts[..., 1]), dtype=np.float64)
    if not hump_above_start:
        return float(max(np.max(g - pts[..., 2]), 0.0))
    # only what lies above the foot's own height as well: stepping down past an edge at the foot's height
    # asks for no rise
    return float(max(np.max(g - np.maximum(pts[..., 2], a[:, None, 2])), 0.0))


def gap_ahead(view: TerrainView, world: TerrainWorld, p: DecisionParams) -> float:
    """Gives the longest run (m) without a region a foot can take (the regions' insets), along the left and right
    feet's lines from gap_behind_m behind to gap_ahead_m ahead of the body, along its heading: the width of the
    widest gap a step must cross (a riser's edge band, a pit between stones, the floor around a box)."""
    regions = world.regions
    res = regions.resolution_m
    s = np.arange(-p.gap_behind_m, p.gap_ahead_m + 1e-9, res)
    c, sn = math.cos(view.yaw), math.sin(view.yaw)
    lat = np.array([float(np.mean(view.p_body_hip[[0, 2], 1])), float(np.mean(view.p_body_hip[[1, 3], 1]))])
    x = view.p_world_body[0] + s[None, :] * c - lat[:, None] * sn
    y = view.p_world_body[1] + s[None, :] * sn + lat[:, None] * c
    nx, ny = regions.labels.shape
    ix = np.rint((x - regions.origin_xy[0]) / res).astype(np.intp)
    iy = np.rint((y - regions.origin_xy[1]) / res).astype(np.intp)
    on = (ix >= 0) & (ix < nx) & (iy >= 0) & (iy < ny)
    cx, cy = (
        np.minimum(np.maximum(ix, 0), nx - 1),
        np.minimum(np.maximum(iy, 0), ny - 1),
    )  # np.clip on integers
    ok = np.where(on, regions.inset[cx, cy], True)
    ground = world.maps.ground_height[cx, cy] if p.gap_dip_m is not None else None
    seen = np.where(on, world.maps.observed[cx, cy], False) if p.gap_dip_m is not None else None
    longest = 0
    for k, row in enumerate(ok):
        # runs of False: from the positions where the row changes
        edges = np.flatnonzero(np.diff(np.concatenate([[1], row.astype(np.int8), [1]])))
        flight = ground is not None and (
            p.gap_flight_steps is None
            or (seen is not None and is_flight(ground[k][seen[k]], p.gap_dip_m, p.gap_flight_steps))
        )
        for a, b in zip(edges[::2], edges[1::2], strict=True):
            if flight and ground is not None and not _dips(ground[k], int(a), int(b), p.gap_dip_m):
                continue
            longest = max(longest, int(b - a))
    return longest * res


def is_flight(ground: NDArray[np.float64], dip_m: float | None, steps: int) -> bool:
    """Whether a line's ground (heights along it, m) is a flight of steps: it goes one way only (up or down, never
    back by more than dip_m from the highest, or lowest, ground before) through at least `steps` height changes of
    more than dip_m, each the change over a run of cells that each change by more than half of dip_m (a riser seen
    over one or a few cells); a single cell out of line with both its neighbours is read at their median."""
    if dip_m is None or ground.size < 2 or not bool(np.all(np.isfinite(ground))):
        return False
    if ground.size >= 3:
        # a cell alone above or below its neighbours (a nosing or a riser's face seen edge-on at the sensor's range)
        # is no step: the median of each cell and its two neighbours
        mid = np.median(np.stack([ground[:-2], ground[1:-1], ground[2:]]), axis=0)
        ground = np.concatenate([ground[:1], mid, ground[-1:]])
    d = np.diff(ground)
    sharp = np.abs(d) > 0.5 * dip_m
    bounds = np.flatnonzero(np.diff(np.concatenate([[0], sharp.astype(np.int8), [0]])))
    changes = [float(np.sum(d[a:b])) for a, b in zip(bounds[::2], bounds[1::2], strict=True)]
    up = sum(1 for c in changes if c > dip_m)
    down = sum(1 for c in changes if c < -dip_m)
    if up >= steps and down == 0:
        return bool(np.all(ground >= np.maximum.accumulate(ground) - dip_m))
    if down >= steps and up == 0:
        return bool(np.all(ground <= np.minimum.accumulate(ground) + dip_m))
    return False


def _dips(ground: NDArray[np.float64], a: int, b: int, dip_m: float | None) -> bool:
    """Whether the run [a, b) of a line without a region is a gap: not where it only goes from one height to
    another (its ends, the cells just outside it, differ by more than dip_m and its ground stays within dip_m of
    the range between them: a riser's edge band, treads a step map lost between two kept ones); a run at the line's
    end (one end) is a gap where its ground dips more than dip_m below that end."""
    if dip_m is None:
        return True
    ends = [float(ground[i]) for i in (a - 1, b) if 0 <= i < ground.size]
    if not ends:
        return True
    seg = ground[a:b]
    lo, hi = min(ends), max(ends)
    if len(ends) == 1:
        return bool(np.min(seg) < lo - dip_m)
    return not (hi - lo > dip_m and float(np.min(seg)) >= lo - dip_m and float(np.max(seg)) <= hi + dip_m)


def capped(cmd: SteeringCommand, cap: float, p: DecisionParams) -> SteeringCommand:
    """Gives the operator's command with its speed within cap and its yaw rate within max_yaw_rate_rps."""
    speed = float(math.hypot(cmd.vx, cmd.vy))
    k = min(1.0, cap / speed) if speed > 1e-9 else 1.0
    return SteeringCommand(
        cmd.vx * k, cmd.vy * k, float(clip_scalar(cmd.yaw_rate, -p.max_yaw_rate_rps, p.max_yaw_rate_rps))
    )


def travel_yaw(view: TerrainView, path: BodyPath, p: DecisionParams) -> float:
    """Gives the direction (rad) from the body's centre to the point lookahead_m on along its path from its nearest
    point (the goal past the path's end): the way the body goes. (Not the path's yaw: a path is planned from the
    body's pose, its yaw blended from the body's over its first metres.)"""
    xy = view.p_world_body[:2]
    k = int(np.argmin(np.sum((path.xy - xy) ** 2, axis=1)))
    s_ahead = float(path.s[k]) + max(p.lookahead_m, 0.1)
    target = path.pose_at(s_ahead)[0] if s_ahead < path.length_m or view.goal is None else view.goal
    d = np.asarray(target, dtype=np.float64) - xy
    if float(np.hypot(d[0], d[1])) < 1e-6:
        return float(path.yaw[k])
    return math.atan2(float(d[1]), float(d[0]))


def path_heights(
    maps: TerrainMaps, path: BodyPath, s: NDArray[np.floating[Any]], lateral_m: float = 0.0
) -> NDArray[np.float64]:
    """Gives the ground height (m) at arc lengths s (m) along the body path, lateral_m to its left (its right:
    below 0); below 0 on the line back from the path's start along its first direction (a path is planned from the
    body, so what lies behind the body is not on it), past its end at its end."""
    xy, yaw = path.pose_at(s)
    before = s < 0.0
    if before.any() and path.xy.shape[0] > 1:
        d = path.xy[1] - path.xy[0]
        d = d / max(float(np.hypot(d[0], d[1])), 1e-9)
        xy[before] = path.xy[0] + s[before, None] * d
        yaw = np.where(before, math.atan2(float(d[1]), float(d[0])), yaw)
    if lateral_m != 0.0:
        xy = xy + lateral_m * np.stack([-np.sin(yaw), np.cos(yaw)], axis=-1)
    return np.asarray(maps.height_at(xy[:, 0], xy[:, 1]), dtype=np.float64)


def descent_edges(
    maps: TerrainMaps,
    path: BodyPath,
    s0: float,
    s1: float,
    p: DecisionParams,
    leg_m: float,
    feet_half_width_m: float = 0.0,
) -> bool:
    """Tells whether a descent edge (see DecisionParams.back_drop_frac) lies on the body path between arc lengths
    s0 and s1 (m; below 0: on the line back from the path's start): sampled at the map's resolution, an edge at
    sample i when the ground falls by back_drop_frac × leg_m or more within back_edge_m after it and stays that much
    lower over the back_beyond_m after that. The ground is read on the feet's two lines, feet_half_width_m to
    either side of the path, and the higher of the two counts (a pit under the body's centre line between two
    stones the feet stand on is no descent)."""
    assert p.back_drop_frac is not None
    res = maps.resolution_m
    ke = max(int(math.ceil(p.back_edge_m / res)), 1)
    kb = max(int(math.ceil(p.back_beyond_m / res)), 1)
    lo = s0
    hi = min(s1, path.length_m)
    if hi <= lo:
        return False
    n = int(math.floor((hi - lo) / res)) + 1  # the edges' samples: within [s0, s1]
    s = lo + res * np.arange(n + ke + kb)
    h = path_heights(maps, path, s, feet_half_width_m)
    if feet_half_width_m != 0.0:
        h = np.maximum(h, path_heights(maps, path, s, -feet_half_width_m))
    drop = p.back_drop_frac * leg_m
    # the highest ground from ke samples after each sample on, over the kb after that (a running max, windowed)
    win = np.lib.stride_tricks.sliding_window_view(h[ke:], kb)[:n].max(axis=1)
    return bool(np.any(h[:n] - win >= drop))


def next_facing(
    view: TerrainView, maps: TerrainMaps, path: BodyPath, facing: Facing, p: DecisionParams
) -> Facing:
    """Gives how the body faces along its path from now (see DecisionParams.back_drop_frac), from how it faced:
    "forward" turns "back" (round in place, then backward) at a descent edge between turn_clear_m and back_ahead_m
    ahead (none nearer: the feet would step off it turning) where there is room to turn (turn_room) and the ground over back_behind_m behind the body's centre is level (within half
    the fall: not on a flight, up or down), as are the feet (measured) and the circle they turn on
    (feet_turn_level); "back" stays while a descent edge lies within back_behind_m behind its centre or
    back_ahead_m ahead, then turns "round" (in place, to face its path); "round" is "forward" again once the body
    is within turn_rad of the way it goes (or "back" at a descent edge ahead)."""
    leg_m = view.l_upper_m + view.l_lower_m
    if p.back_drop_frac is None or leg_m <= 0.0:
        return "forward"
    k = int(np.argmin(np.sum((path.xy - view.p_world_body[:2]) ** 2, axis=1)))
    s = float(path.s[k])
    w = feet_half_width(view)
    if facing == "back":
        # kept with some slack (a lower edge, a little farther ahead), so that an edge measured at the threshold or
        # a path replanned while turning does not end a turn just begun
        keep = dataclasses.replace(p, back_drop_frac=p.back_drop_frac * p.back_keep_frac)
        window = (s - p.back_behind_m, s + p.back_ahead_m + p.back_keep_m)
        return "back" if descent_edges(maps, path, *window, keep, leg_m, w) else "round"
    ahead = descent_edges(maps, path, s + p.turn_clear_m, s + p.back_ahead_m, p, leg_m, w)
    ahead = ahead and not descent_edges(maps, path, s, s + p.turn_clear_m, p, leg_m, w)  # (too near to turn)
    # only on level ground: the ground from back_behind_m behind the body's centre to it spans less than
    # back_level_frac of the fall (not on a flight, up or down: a landing shorter than the body, a tread)
    if ahead:
        under = path_heights(
            maps,
            path,
            s - p.back_behind_m + maps.resolution_m * np.arange(int(p.back_behind_m / maps.resolution_m) + 1),
        )
        level = p.back_level_frac * p.back_drop_frac * leg_m
        # ... the feet down measured level too (stance_feet_level; the map behind a body that has just climbed is
        # filled from its feet, not seen: the mixed family's 0.6 m top read level with the hind feet a tread below;
        # a swinging foot does not count, or a slow gait's turn would wait for a touchdown), and the ground the
        # feet turn on level (feet_turn_level: a landing shorter than the feet's circle is no place to turn)
        ahead = (
            float(np.ptp(under)) < level
            and stance_feet_level(view, level)
            and feet_turn_level(view, maps, level)
        )
    if ahead and turn_way(view, maps, travel_yaw(view, path, p) + math.pi, p):
        return "back"
    if (
        facing == "round"
        and abs(math.remainder(view.yaw - travel_yaw(view, path, p), 2.0 * math.pi)) > p.turn_rad
    ):
        return "round"
    return "forward"


def stance_feet_level(view: TerrainView, level_m: float) -> bool:
    """Tells whether the feet down (view.stance) stand level: at least two of them, their measured heights spanning
    less than level_m. A swinging foot does not count: it is in the air, wherever it is headed."""
    z = view.p_world_foot[view.stance, 2]
    return bool(z.size >= 2 and float(np.ptp(z)) < level_m)


def feet_turn_level(view: TerrainView, maps: TerrainMaps, level_m: float, n: int = 16) -> bool:
    """Tells whether the ground the feet stand on while the body turns in place is level: at n points on the circle
    the feet sweep (the farthest leg plane's distance from the body's centre at its hip, RobotModel, plus the foot's
    radius) and at the centre, the heights span less than level_m."""
    r = float(np.max(np.hypot(view.p_body_hip[:, 0], _leg_plane_y(view)))) + view.foot_radius_m
    a = 2.0 * math.pi * np.arange(n) / n
    x = float(view.p_world_body[0]) + np.concatenate([[0.0], r * np.cos(a)])
    yy = float(view.p_world_body[1]) + np.concatenate([[0.0], r * np.sin(a)])
    return float(np.ptp(np.asarray(maps.height_at(x, yy), dtype=np.float64))) < level_m


def feet_half_width(view: TerrainView) -> float:
    """Gives the feet's lines' half width (m): the mean lateral offset of the legs' planes from the body's axis
    (the hips' offsets plus each leg's plane's offset from its abduction axis, RobotModel)."""
    return float(np.mean(np.abs(_leg_plane_y(view))))


def _leg_plane_y(view: TerrainView) -> NDArray[np.float64]:
    """Gives each leg's plane's lateral offset from the body's axis (4,): its hip's plus its abduction offset (m)."""
    return np.asarray(view.p_body_hip[:, 1] + (0.0 if view.abd_offset_m is None else view.abd_offset_m))


def turn_way(view: TerrainView, maps: TerrainMaps, yaw_to: float, p: DecisionParams) -> int:
    """turn_room with the footprint and margin of p (DecisionParams.turn_circles_x_m, turn_circle_r_m,
    turn_margin_m)."""
    return turn_room(view, maps, yaw_to, p.turn_circles_x_m, p.turn_circle_r_m, p.turn_margin_m)


def turn_room(
    view: TerrainView,
    maps: TerrainMaps,
    yaw_to: float,
    circles_x_m: tuple[float, ...],
    radius_m: float,
    margin_m: float,
) -> int:
    """Gives the way the body can turn in place from its yaw to yaw_to (rad): +1 (counterclockwise) or -1 where every
    footprint circle (centres circles_x_m along the body's axis, radius radius_m) keeps margin_m from body obstacles
    (the body SDF less the edges of drops below the body: maps.sdf_collide; a landing's open side does not hold a
    turn on the landing) at every heading on the way (15° apart or closer), the way of more clearance where both can;
    0: neither can."""
    d = math.remainder(yaw_to - view.yaw, 2.0 * math.pi)
    step = math.pi / 12.0
    xs = np.asarray(circles_x_m, dtype=np.float64)
    x, y = (float(v) for v in view.p_world_body[:2])
    best, best_clear = 0, -np.inf
    for sign in (1, -1):
        arc = abs(d) if (d >= 0.0) == (sign > 0) else 2.0 * math.pi - abs(d)
        th = view.yaw + sign * np.linspace(0.0, arc, int(math.ceil(arc / step)) + 1)
        cx = x + np.outer(np.cos(th), xs).ravel()
        cy = y + np.outer(np.sin(th), xs).ravel()
        clear = float(np.min(np.asarray(maps.sdf_collide(cx, cy), dtype=np.float64))) - radius_m
        if clear >= margin_m and clear > best_clear:
            best, best_clear = sign, clear
    return best


def follow_path(
    view: TerrainView,
    path: BodyPath | None,
    cap: float,
    p: DecisionParams,
    facing: Facing = "forward",
    maps: TerrainMaps | None = None,
) -> SteeringCommand:
    """Gives the body command (body frame) that pursues the point lookahead_m ahead on the body path (the goal at
    its end), at the speed cap (slower near the goal), turning toward the path's yaw; facing "back", against the
    way it goes (a descent walked backward), and, "back" or "round", turning in place while more than turn_rad
    off its yaw (see next_facing)."""
    assert view.goal is not None
    xy = view.p_world_body[:2]
    dist = float(np.linalg.norm(view.goal - xy))
    if dist < p.goal_tolerance_m:
        return SteeringCommand()
    speed = min(cap, p.goal_gain * dist)
    turning = False
    if path is None or path.length_m < 1e-6:
        target, yaw_des = view.goal, view.yaw
    else:
        k = int(np.argmin(np.sum((path.xy - xy) ** 2, axis=1)))
        s_ahead = float(path.s[k]) + p.lookahead_m
        target = path.pose_at(s_ahead)[0] if s_ahead < path.length_m else view.goal
        yaw_des = float(path.yaw[k])
        if p.yaw_lookahead_m > 0.0 and (p.yaw_near_m is None or path.min_clearance_m < p.yaw_near_m):
            yaw_des = float(path.pose_at(float(path.s[k]) + p.yaw_lookahead_m)[1])
        if facing == "back":
            yaw_des = travel_yaw(view, path, p) + math.pi
        turning = facing != "forward"  # a turn round, either way: in place
        if dist <= 0.5:
            yaw_des = view.yaw
            turning = False
    d = np.asarray(target, dtype=np.float64) - xy
    n = float(np.linalg.norm(d))
    if n < 1e-9:
        return SteeringCommand()
    dyaw = float((yaw_des - view.yaw + np.pi) % (2 * np.pi) - np.pi)
    if turning and abs(dyaw) > p.turn_rad:
        speed = 0.0  # a turn round (or a backward walk off its yaw): in place
        if abs(dyaw) > 0.5 * math.pi and maps is not None:
            way = turn_way(view, maps, yaw_des, p)  # the way round with room for the footprint
            if way != 0 and (dyaw > 0.0) != (way > 0):
                dyaw = dyaw - math.copysign(2.0 * math.pi, dyaw)
    v_body = rotate_yaw(-view.yaw, d / n * speed)
    wz = float(clip_scalar(p.yaw_gain * dyaw, -p.max_yaw_rate_rps, p.max_yaw_rate_rps))
    return SteeringCommand(float(v_body[0]), float(v_body[1]), wz)


def footholds_plane(
    view: TerrainView, last: FootholdDecision | None, touchdowns: bool = True
) -> tuple[float, float]:
    """Gives the plane through the support (support_points: stance feet, and for a swinging leg its chosen
    touchdown, or with touchdowns False its last stance height): its height at the body above the mean contact
    height (m), and its slope along the heading (m/m, positive uphill)."""
    pts = support_points(view, last, touchdowns)
    A = np.column_stack([pts[:, 0], pts[:, 1], np.ones(4)])
    coef, *_ = np.linalg.lstsq(A, pts[:, 2], rcond=None)
    a, b, c = (float(v) for v in coef)
    xy = view.p_world_body[:2]
    z_plane = a * float(xy[0]) + b * float(xy[1]) + c
    slope = a * math.cos(view.yaw) + b * math.sin(view.yaw)
    return z_plane - view.z_contact, slope


def support_points(
    view: TerrainView, last: FootholdDecision | None, touchdowns: bool = True
) -> NDArray[np.float64]:
    """Gives each leg's support (4, 3): its stance foot's contact point, or for a swinging leg its chosen
    touchdown (touchdowns; its foot's contact point where none is chosen), or (not touchdowns) its foot's place
    at the height of its last stance foothold (FootholdMemory.z_stance, where known)."""
    pts = view.p_world_foot.copy()
    pts[:, 2] -= view.foot_radius_m
    if last is not None:
        if touchdowns:
            chosen = last.memory.p_chosen
            use = ~view.stance & np.all(np.isfinite(chosen), axis=1)
            pts[use] = chosen[use]
        else:
            z = last.memory.z_stance
            use = ~view.stance & np.isfinite(z)
            pts[use, 2] = z[use]
    return pts


def hips_plane(
    view: TerrainView, last: FootholdDecision | None, touchdowns: bool = True
) -> tuple[float, float]:
    """Gives the support's heights as the hips see them: the least-squares line z = c + g·x through each leg's
    support height (support_points) against its hip's offset x along the body (RobotModel's p_body_hip); returns
    c above the mean contact height (m: the height offset, the support under the body's centre) and −g (the sine
    of the pitch, positive nose down, at which every hip stands equally high above its own support on that
    line: a hip at x along a body pitched θ sits x·sin θ lower, so −sin θ = g)."""
    z = support_points(view, last, touchdowns)[:, 2]
    x = np.asarray(view.p_body_hip[:, 0], dtype=np.float64)
    xm = float(x.mean())
    var = float(((x - xm) ** 2).sum())
    g = float(((x - xm) * (z - z.mean())).sum()) / var if var > 1e-12 else 0.0
    c = float(z.mean()) - g * xm
    return c - view.z_contact, -g


def hips_pairs(
    view: TerrainView, last: FootholdDecision | None, touchdowns: bool = True
) -> tuple[float, float]:
    """Gives hips_plane's two values from each pair's highest support: the line through (the front hips' mean
    offset along the body, the front legs' highest support) and the same for the hind legs (the front hips: those
    ahead of the hips' mean offset; support_points); its height at the body's centre above the mean contact height
    (m) and the sine of its pitch (positive nose down). Every leg's hip then stands at least as high above its own
    support as the highest-standing leg of its pair does."""
    z = support_points(view, last, touchdowns)[:, 2]
    x = np.asarray(view.p_body_hip[:, 0], dtype=np.float64)
    front = x > float(x.mean())
    if not front.any() or front.all():
        return float(z.max()) - view.z_contact, 0.0
    xf, xh = float(x[front].mean()), float(x[~front].mean())
    zf, zh = float(z[front].max()), float(z[~front].max())
    g = (zf - zh) / (xf - xh)
    return zf - g * xf - view.z_contact, -g


def reach_height(view: TerrainView, pitch: float, p: DecisionParams) -> float:
    """Gives the highest body height (m, above the mean contact height) at which every stance foot lies within
    height_reach_frac of the leg's full length of its hip along the heading and up, the hips placed by the pitch
    (positive nose down) (inf: no leg lengths, or no foot bounds it)."""
    return max(_reach_bound(view, view.p_world_foot, view.stance, pitch, p.height_reach_frac), p.min_height_m)


def touchdown_reach_height(
    view: TerrainView, p_chosen: NDArray[np.float64], pitch: float, p: DecisionParams
) -> float:
    """Gives the highest body height (m, above the mean contact height) at which every swinging leg's chosen
    touchdown p_chosen (4, 3: contact points on the ground; nan: none) lies within touchdown_reach_frac of the
    leg's full length of its hip, the hips placed as in reach_height; not below min_height_m (inf: the rule off,
    no leg lengths, or no touchdown bounds it)."""
    if p.touchdown_reach_frac is None:
        return np.inf
    centres = np.asarray(p_chosen, dtype=np.float64).copy()
    centres[:, 2] += view.foot_radius_m
    use = ~view.stance & np.all(np.isfinite(centres), axis=1)
    bound = _reach_bound(view, np.where(use[:, None], centres, 0.0), use, pitch, p.touchdown_reach_frac)
    return max(bound, p.min_height_m)


def _reach_bound(
    view: TerrainView, feet: NDArray[np.float64], which: NDArray[np.bool_], pitch: float, frac: float
) -> float:
    """The highest body height (above the mean contact height) at which every foot centre feet[which] lies within
    frac of its leg's full length of its hip, along the heading and up, the hips placed by the pitch (inf: no leg
    lengths, or no foot bounds it)."""
    length = frac * (view.l_upper_m + view.l_lower_m)
    if view.l_upper_m <= 0.0:
        return np.inf
    u = np.array([math.cos(view.yaw), math.sin(view.yaw)])
    x_hip = view.p_body_hip[:, 0]
    s_hip = float(view.p_world_body[:2] @ u) + x_hip * math.cos(pitch)
    dx = feet[:, :2] @ u - s_hip
    use = which & (np.abs(dx) < length)
    if not use.any():
        return np.inf
    dz = np.sqrt(np.maximum(length**2 - dx[use] ** 2, 0.0))
    return float(np.min(feet[use, 2] + dz - view.z_contact + math.sin(pitch) * x_hip[use]))


@functools.lru_cache(maxsize=8)
def _crouch_offsets(ahead_m: float) -> NDArray[np.float64]:
    """The points crouch_height looks at, in the body's frame (15 along the heading by 3 across, (15, 3, 2))."""
    d = np.linspace(-ahead_m, ahead_m, 15)
    lat = np.array([-0.12, 0.0, 0.12])
    out = np.stack(np.broadcast_arrays(d[:, None], lat[None, :]), -1)
    out.flags.writeable = False
    return out


def crouch_height(
    view: TerrainView, maps: TerrainMaps, p: DecisionParams, overhangs: HeightGrid | None = None
) -> float:
    """Gives the highest body height (m) that keeps the body's top under the overhangs around and ahead of the
    body (the clearance map, and the remembered overhang undersides if given; none: inf, no bound)."""
    xy = view.p_world_body[:2] + rotate_yaw(view.yaw, _crouch_offsets(p.crouch_ahead_m))
    xy = xy.reshape(-1, 2)
    # the clearance and the body obstacles of the nearest cells (as maps.clearance_at and maps.no_body: inf and
    # False off the map), the cells found once for both
    nx, ny = maps.shape
    ix = np.rint((xy[:, 0] - maps.origin_xy[0]) / maps.resolution_m).astype(np.intp)
    iy = np.rint((xy[:, 1] - maps.origin_xy[1]) / maps.resolution_m).astype(np.intp)
    on = (ix >= 0) & (ix < nx) & (iy >= 0) & (iy < ny)
    ix = np.minimum(np.maximum(ix, 0), nx - 1)
    iy = np.minimum(np.maximum(iy, 0), ny - 1)
    c = np.where(on, maps.clearance_m[ix, iy], np.inf)
    wall = on & maps.body_obstacle[ix, iy]
    h_cell = np.asarray(maps.height_at(xy[:, 0], xy[:, 1]), dtype=np.float64)
    z_feet = view.z_contact
    z_ceiling = h_cell + c
    if overhangs is not None:
        z_ceiling = np.minimum(z_ceiling, np.asarray(overhangs(xy[:, 0], xy[:, 1]), dtype=np.float64))
    rel = np.where(wall, np.inf, z_ceiling) - np.maximum(h_cell, z_feet)
    clear = float(np.min(np.where(rel >= p.ceiling_above_m, rel, np.inf)))
    if not np.isfinite(clear):
        return np.inf
    return max(clear - p.body_top_m - p.head_margin_m, p.min_height_m)


def swing_ground(maps: TerrainMaps, radius_m: float) -> HeightGrid:
    """Gives the ground-height map dilated by radius_m (the highest ground within it): what a foot of that radius
    must clear (cells whose centres lie within radius_m; read at the nearest cell, so an edge up to a cell closer
    may be missed: the swing planner's cliff rings probe beyond it)."""
    res = maps.resolution_m
    r = max(int(math.ceil(radius_m / res - 1e-9)), 0)
    i = np.arange(-r, r + 1)
    disk = (i[:, None] ** 2 + i[None, :] ** 2) * res * res <= radius_m**2 + 1e-12
    # The disk's empty outer rings left out (a radius under a cell: the cell alone), then gridops' row-run filter:
    # ndimage.maximum_filter's values with mode "nearest", in a fraction of its time.
    while disk.shape[0] > 1 and not disk[0].any():
        disk = disk[1:-1, 1:-1]
    h = disk_filter(maps.ground_height, disk, np.maximum) if disk.shape[0] > 1 else maps.ground_height
    return HeightGrid(maps.origin_xy, res, np.asarray(h, dtype=np.float64))


def own_side(p: DecisionParams) -> float:
    """Gives how far a foothold's centre lies at least on its leg's side of the body's centre line (m): the foot's
    radius plus own_side_m (-inf: no bound)."""
    return -math.inf if p.own_side_m is None else p.regions.foot_radius_m + p.own_side_m


def choose_region(
    regions: SteppableRegions,
    maps: TerrainMaps,
    xy: NDArray[np.float64],
    z_ref: float,
    keep_xy: NDArray[np.float64] | None,
    p: DecisionParams,
    in_flight: bool = False,
    hip: NDArray[np.float64] | None = None,
    reach_m: float = np.inf,
    side: NDArray[np.float64] | None = None,
    exclude: frozenset[int] = frozenset(),
) -> int:
    """Gives the region (label; 0: none) for a foothold whose nominal place is xy (2,), for a leg whose last
    foothold was at height z_ref (m): among the regions with an inset cell within search_m, those within
    max_rise_m of z_ref, the one of least distance + w_height × |height change|; the region under keep_xy (the
    previous choice) is kept unless another costs keep_m less, and while the foot is in flight (in_flight) as long
    as it is within reach at all: a swing commits to its region at liftoff. hip (2,): the leg's hip at touchdown;
    cells farther than reach_m from it (in the ground plane) are out of reach. side (4,): the body's centre at
    touchdown (x, y) and the unit vector from it toward the leg's side: only cells own_side(p) or more along
    it are chosen (see DecisionParams.own_side_m). exclude: labels not to choose (shin_region: rejected)."""
    res = regions.resolution_m
    ox, oy = regions.origin_xy
    w = int(math.ceil(p.search_m / res))
    nx, ny = regions.labels.shape
    x, y = float(xy[0]), float(xy[1])
    cx = int(round((x - ox) / res))
    cy = int(round((y - oy) / res))
    i0, i1, j0, j1 = max(cx - w, 0), min(cx + w + 1, nx), max(cy - w, 0), min(cy + w + 1, ny)
    if i0 >= i1 or j0 >= j1:
        return 0
    # The window's inset cells (the inset's labels cached per regions object); x depends on a cell's row only and
    # y on its column only.
    lab = regions.inset_labels[i0:i1, j0:j1]
    ci, cj = lab.nonzero()
    if ci.size == 0:
        return 0
    labs = lab[ci, cj]
    dx = (ox + np.arange(i0, i1) * res - x)[ci]
    dy = (oy + np.arange(j0, j1) * res - y)[cj]
    dist = np.hypot(dx, dy)
    dz = np.abs(maps.ground_height[i0:i1, j0:j1][ci, cj] - z_ref)
    ok = (dist <= p.search_m) & (dz <= p.max_rise_m)
    if hip is not None and np.isfinite(reach_m):
        ok &= np.hypot(dx + x - float(hip[0]), dy + y - float(hip[1])) <= reach_m
    if side is not None and p.own_side_m is not None:
        bx, by, sx, sy = (float(v) for v in side)
        ok &= (dx + x - bx) * sx + (dy + y - by) * sy >= own_side(p)
    if exclude:
        ok &= ~np.isin(labs, np.fromiter(exclude, dtype=labs.dtype))
    cost = np.where(ok, dist + p.w_height * dz, np.inf)
    # The region of least cost (a region's cost: its least over its cells; a tie: the lowest label).
    least = float(cost.min())
    if not math.isfinite(least):
        return 0
    choice = int(labs[cost == least].min())
    if keep_xy is not None:
        prev = regions.label_at(float(keep_xy[0]), float(keep_xy[1]))
        if 0 < prev <= int(labs.max()) and prev not in exclude:
            mine = labs == prev
            prev_cost = float(cost[mine].min()) if mine.any() else np.inf
            if prev_cost <= least + (np.inf if in_flight else p.keep_m):
                return prev
    return choice


def _choose_regions(
    regions: SteppableRegions,
    maps: TerrainMaps,
    xys: NDArray[np.float64],
    z_refs: list[float],
    keeps: list[NDArray[np.float64] | None],
    p: DecisionParams,
    flying: list[bool],
    hips: NDArray[np.float64],
    reach_m: float,
    sides: NDArray[np.float64] | None = None,
) -> list[int]:
    """choose_region for several footholds at once (xys (S, 2), a height reference, kept place, flight flag,
    hip (S, 2) and side (S, 4) each): the window cells of all of them in one set of arrays, each one's least cost,
    lowest label of it and kept region's least cost by segment (min / max are exact in any order: the same
    answers)."""
    S = len(z_refs)
    if S == 1:
        side = None if sides is None else sides[0]
        return [
            choose_region(regions, maps, xys[0], z_refs[0], keeps[0], p, flying[0], hips[0], reach_m, side)
        ]
    res = regions.resolution_m
    ox, oy = regions.origin_xy
    w = int(math.ceil(p.search_m / res))
    nx, ny = regions.labels.shape
    parts: list[tuple[NDArray[Any], ...]] = []
    seg: list[int] = []  # the slots with window cells, in order
    for s, (x, y) in enumerate(xys.tolist()):
        cx = int(round((x - ox) / res))
        cy = int(round((y - oy) / res))
        i0, i1, j0, j1 = max(cx - w, 0), min(cx + w + 1, nx), max(cy - w, 0), min(cy + w + 1, ny)
        if i0 >= i1 or j0 >= j1:
            continue
        lab = regions.inset_labels[i0:i1, j0:j1]
        ci, cj = lab.nonzero()
        if ci.size == 0:
            continue
        parts.append(
            (
                lab[ci, cj],
                (ox + np.arange(i0, i1) * res - x)[ci],
                (oy + np.arange(j0, j1) * res - y)[cj],
                maps.ground_height[i0:i1, j0:j1][ci, cj],
            )
        )
        seg.append(s)
    out = [0] * S
    if not seg:
        return out
    sizes = np.array([len(part[0]) for part in parts])
    starts = np.concatenate([[0], np.cumsum(sizes)[:-1]])
    labs, dx, dy, hc = (np.concatenate([part[i] for part in parts]) for i in range(4))
    rep = np.repeat(np.arange(len(seg)), sizes)
    seg_a = np.array(seg)
    z_cell = np.array(z_refs)[seg_a][rep]
    dist = np.hypot(dx, dy)
    dz = np.abs(hc - z_cell)
    ok = (dist <= p.search_m) & (dz <= p.max_rise_m)
    if np.isfinite(reach_m):
        x_cell = xys[seg_a, 0][rep]
        y_cell = xys[seg_a, 1][rep]
        ok &= np.hypot(dx + x_cell - hips[seg_a, 0][rep], dy + y_cell - hips[seg_a, 1][rep]) <= reach_m
    if sides is not None and p.own_side_m is not None:
        sd = sides[seg_a][rep]
        ok &= (dx + xys[seg_a, 0][rep] - sd[:, 0]) * sd[:, 2] + (dy + xys[seg_a, 1][rep] - sd[:, 1]) * sd[
            :, 3
        ] >= own_side(p)
    cost = np.where(ok, dist + p.w_height * dz, np.inf)
    least = np.minimum.reduceat(cost, starts)
    big = np.iinfo(labs.dtype).max
    lowest = np.minimum.reduceat(np.where(cost == least[rep], labs, big), starts)
    top = np.maximum.reduceat(labs, starts)
    prev = np.zeros(len(seg), dtype=labs.dtype)
    for g, s in enumerate(seg):
        keep = keeps[s]
        if keep is not None:
            prev[g] = regions.label_at(float(keep[0]), float(keep[1]))
    prev_cost = np.minimum.reduceat(np.where(labs == prev[rep], cost, np.inf), starts)
    for g, s in enumerate(seg):
        if not math.isfinite(float(least[g])):
            continue
        choice = int(lowest[g])
        pv = int(prev[g])
        if keeps[s] is not None and 0 < pv <= int(top[g]):
            if float(prev_cost[g]) <= float(least[g]) + (np.inf if flying[s] else p.keep_m):
                choice = pv
        out[s] = choice
    return out


def lost_region(
    regions: SteppableRegions, maps: TerrainMaps, p_prev: NDArray[np.float64], p: DecisionParams
) -> bool:
    """Tells whether a previous foothold p_prev (3,) lies on no region in this map while the ground there is
    still within lost_hold_m of its height (the segmentation lost the cell, the ground did not move)."""
    if regions.label_at(float(p_prev[0]), float(p_prev[1])) != 0:
        return False
    z = float(maps.height_at(float(p_prev[0]), float(p_prev[1])))
    return abs(z - float(p_prev[2])) <= p.lost_hold_m


def knee_points(
    hip: NDArray[np.float64], feet: NDArray[np.float64], l_upper: float, l_lower: float
) -> tuple[NDArray[np.float64], NDArray[np.bool_]]:
    """Gives the knees (C, 2) of a leg whose hip is at hip (2,) and whose foot is at each of feet (C, 2), all
    (along the heading, up) in the leg's plane, with the knee behind the hip-foot line (a knee that points back;
    a foot beyond the leg's length: the leg straight toward it, as the body will come down to it), and whether
    each foot is far enough from the hip for the leg to fold to it."""
    d = feet - hip  # (hip (2,), or one per foot (C, 2))
    D = np.hypot(d[:, 0], d[:, 1])
    reach = D > abs(l_upper - l_lower) + 1e-3
    Ds = np.where(reach, np.minimum(D, l_upper + l_lower - 1e-3), 1.0)
    a = (l_upper**2 - l_lower**2 + Ds**2) / (2.0 * Ds)
    h = np.sqrt(np.maximum(l_upper**2 - a**2, 0.0))
    e = d / Ds[:, None]
    perp = np.stack([-e[:, 1], e[:, 0]], axis=1)
    perp *= np.where(perp[:, 0] > 0.0, -1.0, 1.0)[:, None]  # toward the back
    return hip + a[:, None] * e + h[:, None] * perp, reach


def _ground_nearest(maps: TerrainMaps, x: NDArray[np.float64], y: NDArray[np.float64]) -> NDArray[np.float64]:
    """Gives the ground height (m) of the cells nearest to world (x, y) (border cells beyond the map)."""
    nx, ny = maps.ground_height.shape
    res = maps.resolution_m
    # (np.clip's values through minimum / maximum, without its dispatch cost)
    ix = np.minimum(np.maximum(np.rint((x - maps.origin_xy[0]) / res), 0), nx - 1).astype(np.intp)
    iy = np.minimum(np.maximum(np.rint((y - maps.origin_xy[1]) / res), 0), ny - 1).astype(np.intp)
    return np.asarray(maps.ground_height[ix, iy], dtype=np.float64)


def reach_xy(view: TerrainView, p: DecisionParams) -> float:
    """Gives how far (m) a foothold may lie from its hip at touchdown in the ground plane: where the leg at
    reach_frac of its full length (thigh + shank) meets the ground with the hip at the standing height (inf
    without the leg's lengths)."""
    length = p.reach_frac * (view.l_upper_m + view.l_lower_m)
    if view.l_upper_m <= 0.0 or length <= view.standing_height_m:
        return np.inf
    return math.sqrt(length**2 - view.standing_height_m**2)


def hip_height(view: TerrainView, leg: int) -> float:
    """Gives the height (m) of leg `leg`'s hip: the body's height target above the mean contact height, the
    pitch target applied to the hip's offset along the body."""
    return view.z_contact + view.height_m - math.sin(view.pitch_rad) * float(view.p_body_hip[leg, 0])


def leg_clearance(
    view: TerrainView,
    maps: TerrainMaps,
    leg: int,
    hip_xy: NDArray[np.float64],
    feet_xy: NDArray[np.float64],
    p: DecisionParams,
) -> tuple[NDArray[np.float64], NDArray[np.bool_]]:
    """Gives, for footholds feet_xy (C, 2) of leg `leg` with its hip at hip_xy (2,) at touchdown: the shin's
    clearance (m) and whether the foot is within reach of the hip (reach_xy). The clearance, shin_rule "segment":
    the least height of the shin's surface above the ground along the segment from the foot to the knee
    (shin_segment_clearance; -inf: out of reach), compared with shin_margin_m; "line": the least distance from
    the shin's axis to the ground along the heading behind the foot (shin_behind_m) where it stands more than
    shin_edge_m above the ground's own slope at the foot carried back (a slope is no edge) (inf: no such ground;
    -inf: out of reach), compared with shin_clear_m; "both": the lesser of the two less their thresholds,
    compared with 0 (shin_needed)."""
    return _clearance(view, maps, hip_height(view, leg), hip_xy, feet_xy, p, leg)


def shin_needed(p: DecisionParams) -> float:
    """Gives the clearance (m) leg_clearance's first value must reach for a foothold's shin to pass."""
    return {"line": p.shin_clear_m, "segment": p.shin_margin_m}.get(p.shin_rule, 0.0)


def shin_knees(
    hip: NDArray[np.float64],
    feet: NDArray[np.float64],
    fwd: NDArray[np.float64],
    left: NDArray[np.float64],
    offset: Any,
    l_upper: float,
    l_lower: float,
) -> tuple[NDArray[np.float64], NDArray[np.bool_]]:
    """Gives the knees (C, 3) of a leg whose abduction axis passes through hip ((3,) or one per foot (C, 3)) along
    the body's forward axis fwd (3,), the body's left being left (3,), for feet (C, 3) (foot centres), the leg's
    plane offset from that axis by offset (m, left +; a scalar or (C,)): the plane is rolled about the axis until
    it holds the foot, the knee in it behind the line from the thigh's pivot to the foot (a knee that points
    back; a foot beyond the leg's length: the leg straight toward it); and whether each foot lies outside the
    offset and far enough from the pivot for the leg to fold to it."""
    up = np.cross(fwd, left)
    r = feet - hip
    ry, rz = r @ left, r @ up
    y = np.broadcast_to(np.asarray(offset, dtype=np.float64), ry.shape)
    rho = np.hypot(ry, rz)
    ok = rho > np.abs(y) + 1e-6
    th = np.arctan2(rz, ry) + np.arccos(np.clip(y / np.maximum(rho, 1e-9), -1.0, 1.0))
    n = np.cos(th)[:, None] * left[None, :] + np.sin(th)[:, None] * up[None, :]  # the plane's normal
    pivot = hip + y[:, None] * n
    d = feet - pivot
    D = np.linalg.norm(d, axis=1)
    reach = ok & (D > abs(l_upper - l_lower) + 1e-3)
    Ds = np.where(reach, np.minimum(D, l_upper + l_lower - 1e-3), 1.0)
    a = (l_upper**2 - l_lower**2 + Ds**2) / (2.0 * Ds)
    h = np.sqrt(np.maximum(l_upper**2 - a**2, 0.0))
    e = d / np.maximum(D, 1e-9)[:, None]
    w = np.cross(n, e)  # in the plane, across the pivot-foot line
    w *= np.where(w @ fwd > 0.0, -1.0, 1.0)[:, None]  # toward the back
    return pivot + a[:, None] * e + h[:, None] * w, reach


def shin_segment_clearance(
    maps: TerrainMaps,
    feet: NDArray[np.float64],
    knees: NDArray[np.float64],
    skip_m: float,
    radius_m: float,
    slope: NDArray[np.float64] | None = None,
) -> NDArray[np.float64]:
    """Gives, for shins from feet (C, 3) to knees (C, 3), the least height (m) of the shin's surface above the
    ground: at points along each segment a cell apart from skip_m past the foot's centre, and the knee, the
    point's height less radius_m less the highest ground of the maps within radius_m of the point (a 3 × 3
    stencil) (negative: the shin would stand in the ground, an edge beside or behind the foot). Heights are
    taken above the ground's own plane at each foot (slope (C, 2): dz/dx, dz/dy; None: level): a plain slope is
    no edge. (The decisions skip the foot's radius, the shin's and the margin asked: on a plane, a shin leaning
    less than ~70° from it then always clears by that margin, the foot's own ground being the foot's.)"""
    res = maps.resolution_m
    seg = knees - feet
    L = np.linalg.norm(seg, axis=1)
    # a cell apart from skip_m on, the last at the knee (each row's points its own, whatever the others')
    m = max(1, int(math.ceil(max(float(np.max(L, initial=0.0)) - skip_m, 0.0) / res)) + 1)
    along = np.minimum(skip_m + res * np.arange(m)[None, :], L[:, None])  # (C, M)
    tt = along / np.maximum(L, 1e-9)[:, None]
    pts = feet[:, None, :] + tt[..., None] * seg[:, None, :]  # (C, M, 3)
    off = np.array([-radius_m, 0.0, radius_m])
    ox, oy = np.meshgrid(off, off, indexing="ij")
    xs = pts[..., 0][..., None] + ox.ravel()  # (C, M, 9)
    ys = pts[..., 1][..., None] + oy.ravel()
    g = _ground_nearest(maps, xs.ravel(), ys.ravel()).reshape(xs.shape)
    z = pts[..., 2]
    if slope is not None:
        sx, sy = slope[:, 0][:, None], slope[:, 1][:, None]
        fx, fy = feet[:, 0][:, None], feet[:, 1][:, None]
        g = g - (sx[..., None] * (xs - fx[..., None]) + sy[..., None] * (ys - fy[..., None]))
        z = z - (sx * (pts[..., 0] - fx) + sy * (pts[..., 1] - fy))
    return np.asarray(np.min(z - radius_m - g.max(axis=-1), axis=1), dtype=np.float64)


def foot_slope(maps: TerrainMaps, feet_xy: NDArray[np.float64]) -> NDArray[np.float64]:
    """Gives the ground's own slope (C, 2: dz/dx, dz/dy) at footholds feet_xy (C, 2): along each axis the gentler
    of the one-sided differences over two cells (an edge beside the foot leaves the other side's; on a slope both
    are the slope's)."""
    step = 2.0 * maps.resolution_m
    C = len(feet_xy)
    dx, dy = np.array([step, 0.0]), np.array([0.0, step])
    every = np.concatenate([feet_xy, feet_xy + dx, feet_xy - dx, feet_xy + dy, feet_xy - dy])
    z = _ground_nearest(maps, every[:, 0], every[:, 1]).reshape(5, C)
    out = np.empty((C, 2))
    for k in range(2):
        fwd = (z[1 + 2 * k] - z[0]) / step
        bwd = (z[0] - z[2 + 2 * k]) / step
        out[:, k] = np.where(np.abs(fwd) <= np.abs(bwd), fwd, bwd)
    return out


def _clearance(
    view: TerrainView,
    maps: TerrainMaps,
    z_hip: Any,
    hip_xy: NDArray[np.float64],
    feet_xy: NDArray[np.float64],
    p: DecisionParams,
    legs: Any = 0,
) -> tuple[NDArray[np.float64], NDArray[np.bool_]]:
    """leg_clearance with the hip's height z_hip (m) and place hip_xy (2,), or one of each per foot ((C,), (C, 2)),
    for leg `legs` (or one per foot (C,)): several legs' footholds in one evaluation, the same arithmetic row by
    row. (Along the heading, as in leg_clearance, rows are -inf where the leg cannot fold to the foot as soon as
    any row has an edge behind it: a row alone without one would give inf. The footholds' batched test then sends
    that slot through leg_bounds, which decides as before.)"""
    within = np.hypot(*(feet_xy - hip_xy).T) <= reach_xy(view, p)
    if p.shin_rule == "line":
        return _line_clearance(view, maps, z_hip, hip_xy, feet_xy, p), within
    seg = _segment_clearance(view, maps, z_hip, hip_xy, feet_xy, p, legs)
    if p.shin_rule == "segment":
        return seg, within
    line = _line_clearance(view, maps, z_hip, hip_xy, feet_xy, p)
    return np.minimum(line - p.shin_clear_m, seg - p.shin_margin_m), within


def _segment_clearance(
    view: TerrainView,
    maps: TerrainMaps,
    z_hip: Any,
    hip_xy: NDArray[np.float64],
    feet_xy: NDArray[np.float64],
    p: DecisionParams,
    legs: Any,
) -> NDArray[np.float64]:
    """_clearance's shin_rule "segment" (-inf: the leg cannot fold to the foot)."""
    c, sn = math.cos(view.yaw), math.sin(view.yaw)
    cp, sp = math.cos(view.pitch_rad), math.sin(view.pitch_rad)
    fwd = np.array([cp * c, cp * sn, -sp])  # (a positive pitch: the nose down, as hip_height)
    left = np.array([-sn, c, 0.0])
    z_feet = _ground_nearest(maps, feet_xy[:, 0], feet_xy[:, 1])
    feet3 = np.column_stack([feet_xy, z_feet + view.foot_radius_m])
    if hip_xy.ndim == 1:
        hip3: NDArray[np.float64] = np.array([hip_xy[0], hip_xy[1], float(z_hip)])
    else:
        hip3 = np.column_stack([hip_xy, np.asarray(z_hip, dtype=np.float64)])
    abd = np.zeros(4) if view.abd_offset_m is None else np.asarray(view.abd_offset_m, dtype=np.float64)
    offset = abd[np.broadcast_to(np.asarray(legs, dtype=np.intp), (len(feet_xy),))]
    knees, reach = shin_knees(hip3, feet3, fwd, left, offset, view.l_upper_m, view.l_lower_m)
    skip = view.foot_radius_m + view.shin_radius_m + p.shin_margin_m
    slope = foot_slope(maps, feet_xy)
    clear = shin_segment_clearance(maps, feet3, knees, skip, view.shin_radius_m, slope)
    return np.where(reach, clear, -np.inf)


def _line_clearance(
    view: TerrainView,
    maps: TerrainMaps,
    z_hip: Any,
    hip_xy: NDArray[np.float64],
    feet_xy: NDArray[np.float64],
    p: DecisionParams,
) -> NDArray[np.float64]:
    """_clearance's shin_rule "line" (see leg_clearance)."""
    c, sn = math.cos(view.yaw), math.sin(view.yaw)
    u = np.array([c, sn])
    res = maps.resolution_m
    s_feet = feet_xy @ u
    if hip_xy.ndim == 1:
        hip2 = np.array([float(hip_xy @ u), z_hip])
    else:
        hip2 = np.column_stack([hip_xy @ u, np.asarray(z_hip, dtype=np.float64)])
    ds = np.arange(-p.shin_behind_m, 0.05 + 1e-9, res)
    pts = feet_xy[:, None, :] + ds[None, :, None] * u[None, None, :]
    # the ground's own slope at the foot along the heading: the gentler of the one-sided differences over two
    # cells (a nosing just behind the foot leaves the side ahead; on a slope both are the slope's)
    step = 2.0 * res
    ahead = feet_xy + step * u[None, :]
    behind = feet_xy - step * u[None, :]
    # the ground under the feet, the points behind them, and two cells ahead and behind: one lookup
    C, M = len(feet_xy), len(ds)
    every = np.concatenate([feet_xy, pts.reshape(-1, 2), ahead, behind])
    z_all = _ground_nearest(maps, every[:, 0], every[:, 1])
    z_feet = z_all[:C]
    g = z_all[C : C + C * M].reshape(C, M)
    fwd = (z_all[C + C * M : 2 * C + C * M] - z_feet) / step
    bwd = (z_feet - z_all[2 * C + C * M :]) / step
    feet2 = np.stack([s_feet, z_feet + view.foot_radius_m], axis=1)
    slope = np.where(np.abs(fwd) <= np.abs(bwd), fwd, bwd)
    base = z_feet[:, None] + slope[:, None] * ds[None, :]
    edge = g > base + p.shin_edge_m
    if not edge.any():
        return np.full(len(feet_xy), np.inf)
    pt2 = np.stack([s_feet[:, None] + ds[None, :], g], axis=-1)  # (C, M, 2)
    knee, reach = knee_points(hip2, feet2, view.l_upper_m, view.l_lower_m)
    shin = feet2 - knee  # (C, 2)
    t = np.clip(
        np.sum((pt2 - knee[:, None, :]) * shin[:, None, :], axis=-1)
        / np.maximum(np.sum(shin * shin, axis=1), 1e-12)[:, None],
        0.0,
        1.0,
    )
    off = pt2 - (knee[:, None, :] + t[..., None] * shin[:, None, :])
    dist = np.hypot(off[..., 0], off[..., 1])
    clear = np.min(np.where(edge, dist, np.inf), axis=1)
    return np.where(reach, clear, -np.inf)


def leg_bounds(
    view: TerrainView,
    maps: TerrainMaps,
    leg: int,
    hip_xy: NDArray[np.float64],
    nom: NDArray[np.float64],
    poly: ConvexRegion,
    p: DecisionParams,
) -> list[tuple[NDArray[np.float64], float]]:
    """Gives half-planes (a (2,), b: a·x <= b) along the heading keeping a foothold of leg `leg` where its shin
    clears the ground behind it by shin_clear_m and its hip is within reach (see leg_clearance): none when the
    nominal foothold's place in its polygon already is; else bounds around the nearest place within shin_search_m
    inside the polygon that is (or, none being, the one of the most clearance within reach, or the nearest one
    within reach): the run of such places along the heading, bounded where it ends inside the polygon."""
    return leg_bounds_found(view, maps, leg, hip_xy, nom, poly, p)[0]


def leg_bounds_found(
    view: TerrainView,
    maps: TerrainMaps,
    leg: int,
    hip_xy: NDArray[np.float64],
    nom: NDArray[np.float64],
    poly: ConvexRegion,
    p: DecisionParams,
) -> tuple[list[tuple[NDArray[np.float64], float]], bool]:
    """Gives leg_bounds' half-planes and whether a place they keep clears the shin (False: places within reach
    were found but none clears it, and the bounds keep the one of most clearance; True also where nothing is
    within reach or the view has no leg lengths: nothing to hold for)."""
    if view.l_upper_m <= 0.0 or view.l_lower_m <= 0.0:
        return [], True
    c, sn = math.cos(view.yaw), math.sin(view.yaw)
    u = np.array([c, sn])
    base = poly.project(nom)
    clear0, within0 = leg_clearance(view, maps, leg, hip_xy, base[None, :], p)
    if clear0[0] >= shin_needed(p) and within0[0]:
        return [], True  # (most footholds: one evaluation)
    res = maps.resolution_m
    ds = np.arange(-p.shin_search_m, p.shin_search_m + 1e-9, res)
    ds = np.append(0.0, ds[np.abs(ds) > 1e-9])
    cand = base[None, :] + ds[:, None] * u[None, :]
    inside = np.asarray(poly.contains(cand, 1e-6), dtype=bool)
    inside[0] = True  # the nominal's own place
    ds, cand = ds[inside], cand[inside]
    clear, within = leg_clearance(view, maps, leg, hip_xy, cand, p)
    ok = (clear >= shin_needed(p)) & within
    if ok[0]:
        return [], True
    found = bool(ok.any())
    if found:
        good = ok
    elif within.any():
        best = float(np.max(np.where(within, clear, -np.inf)))
        good = within & (clear >= best - 1e-9) if np.isfinite(best) else within
    else:
        return [], True
    order = np.argsort(ds)
    d_sorted, g_sorted = ds[order], good[order]
    k = int(np.argmin(np.where(g_sorted, np.abs(d_sorted), np.inf)))
    lo = hi = k
    while lo > 0 and g_sorted[lo - 1]:
        lo -= 1
    while hi < d_sorted.size - 1 and g_sorted[hi + 1]:
        hi += 1
    s0 = float(base @ u)
    out: list[tuple[NDArray[np.float64], float]] = []
    if lo > 0:  # places behind the run are not good: the foot at least this far along the heading
        out.append((-u, -(s0 + float(d_sorted[lo]))))
    if hi < d_sorted.size - 1:  # nor ahead of it
        out.append((u, s0 + float(d_sorted[hi])))
    return out, found


def _piece_centre(
    regions: SteppableRegions,
    label: int,
    nom: NDArray[np.float64],
    keep: NDArray[np.float64] | None,
    flying: bool,
) -> NDArray[np.float64]:
    """Gives the place a foothold's polygon is grown around: the nominal foothold nom (2,), or, for a foot in the air
    due within flight_piece_s (flying) whose kept foothold keep (2,) lies on this same region (label), the kept
    foothold: a swing's end commits to the convex piece of its region it was headed for, not only to the region. (The
    floor between boxes is one region of many convex pieces; a nominal flickering across a box sent the target
    0.4 m back and forth in a swing's last 0.2 s, the foot cut the box: clutter draw 240.)"""
    if not (flying and keep is not None):
        return nom
    if regions.label_at(float(keep[0]), float(keep[1])) != label:
        return nom
    return keep


def _polygon(
    regions: SteppableRegions,
    label: int,
    nom: NDArray[np.float64],
    p: DecisionParams,
    cache: dict[tuple[int, int, int], ConvexRegion | None],
) -> ConvexRegion | None:
    """Gives region `label`'s polygon around the nominal foothold nom (2,) (convex_around), cached by region and
    nominal cell."""
    res = regions.resolution_m
    key = (label, int(round(float(nom[0]) / res)), int(round(float(nom[1]) / res)))
    if key not in cache:
        cache[key] = convex_around(regions, label, nom, p.window_m)
    return cache[key]


def shin_region(
    view: TerrainView,
    world: TerrainWorld,
    leg: int,
    hip_xy: NDArray[np.float64],
    nom: NDArray[np.float64],
    z_ref: float,
    keep_xy: NDArray[np.float64] | None,
    flying: bool,
    side: NDArray[np.float64] | None,
    label: int,
    poly: ConvexRegion,
    p: DecisionParams,
    cache: dict[tuple[int, int, int], ConvexRegion | None] | None = None,
) -> tuple[int, ConvexRegion]:
    """The shin test as a region filter (DecisionParams.shin_regions): gives the region and polygon of a next
    touchdown of leg `leg` (hip at hip_xy (2,) at touchdown, nominal foothold nom (2,)), given the region chosen
    for it (label, poly): that one when a place of it along the heading clears the shin (leg_bounds_found), else
    the region choose_region gives without the regions rejected so far (the same height reference z_ref, kept
    place, flight flag, reach and side as the first choice), the first one, up to shin_regions in all, with a place
    that clears; none: the region given (its place of most clearance is then taken, as without the filter)."""
    if p.shin_regions <= 1:
        return label, poly
    cache = {} if cache is None else cache
    maps, regions = world.maps, world.regions
    if leg_bounds_found(view, maps, leg, hip_xy, nom, poly, p)[1]:
        return label, poly
    rejected = {label}
    reach = reach_xy(view, p)
    while len(rejected) < p.shin_regions:
        other = choose_region(
            regions, maps, nom, z_ref, keep_xy, p, flying, hip_xy, reach, side, frozenset(rejected)
        )
        if not other or other in rejected:
            break
        rejected.add(other)
        q = _polygon(regions, other, nom, p, cache)
        if q is not None and leg_bounds_found(view, maps, leg, hip_xy, nom, q, p)[1]:
            return other, q
    return label, poly


def shin_cell_cost(
    clear: NDArray[np.float64], within: NDArray[np.bool_], needed: float, cost_m: float
) -> NDArray[np.float64]:
    """Gives the region cost's shin term (m) of footholds whose shin clearances are clear (C,) (leg_clearance's
    first value) and reach flags within (C,): 0 where the shin clears (at least needed, shin_needed) within reach,
    cost_m elsewhere (DecisionParams.shin_region_cost_m)."""
    return np.where((clear >= needed) & within, 0.0, float(cost_m))


def shin_choice(
    base_cost: NDArray[np.float64],
    shin_cost: NDArray[np.float64],
    keep: int | None,
    keep_m: float,
    flying: bool = False,
    kept_ok: bool = False,
) -> int:
    """Gives the cell (an index) a foothold's polygon is grown around under DecisionParams.shin_region_cost_m,
    given each candidate cell's cost (base_cost (N,): distance + height term) and shin term (shin_cost (N,),
    shin_cell_cost): the cell of least total cost when its shin clears (shin term 0), the kept cell (keep: an
    index, the choice made before) instead while it clears and costs at most keep_m more; -1: no cell, or the
    cell of least cost does not clear (no reachable place clears within the shin term's reach: no change). A foot
    in the air (flying) only keeps its choice: the kept cell while it clears, or while kept_ok (it cleared when it
    was chosen: a clearance that moves by a few millimetres with the hip's estimate late in a swing does not send
    the foot back past the box), else -1."""
    if base_cost.size == 0:
        return -1
    if flying:
        if keep is not None and 0 <= keep < base_cost.size and (shin_cost[keep] <= 0.0 or kept_ok):
            return keep
        return -1
    total = base_cost + shin_cost
    best = int(np.argmin(total))
    if not math.isfinite(float(total[best])) or shin_cost[best] > 0.0:
        return -1
    if keep is not None and 0 <= keep < total.size and shin_cost[keep] <= 0.0:
        if float(total[keep]) <= float(total[best]) + keep_m:
            return keep
    return best


def _shin_cells(
    regions: SteppableRegions,
    maps: TerrainMaps,
    xy: NDArray[np.float64],
    z_ref: float,
    p: DecisionParams,
    hip: NDArray[np.float64],
    reach_m: float,
    side: NDArray[np.float64] | None,
) -> tuple[NDArray[np.float64], NDArray[np.int32], NDArray[np.float64]]:
    """Gives the inset cells (world xy (N, 2), labels (N,), cost (N,): distance + w_height × height change) within
    shin_region_search_m of xy (2,) that choose_region would take (within max_rise_m of z_ref, reach_m of hip (2,),
    own side)."""
    res = regions.resolution_m
    ox, oy = regions.origin_xy
    w = int(math.ceil(p.shin_region_search_m / res))
    nx, ny = regions.labels.shape
    x, y = float(xy[0]), float(xy[1])
    cx, cy = int(round((x - ox) / res)), int(round((y - oy) / res))
    i0, i1, j0, j1 = max(cx - w, 0), min(cx + w + 1, nx), max(cy - w, 0), min(cy + w + 1, ny)
    if i0 >= i1 or j0 >= j1:
        return np.zeros((0, 2)), np.zeros(0, dtype=np.int32), np.zeros(0)
    lab = regions.inset_labels[i0:i1, j0:j1]
    ci, cj = lab.nonzero()
    px = ox + (i0 + ci) * res
    py = oy + (j0 + cj) * res
    dist = np.hypot(px - x, py - y)
    dz = np.abs(maps.ground_height[i0:i1, j0:j1][ci, cj] - z_ref)
    ok = (dist <= p.shin_region_search_m) & (dz <= p.max_rise_m)
    if np.isfinite(reach_m):
        ok &= np.hypot(px - float(hip[0]), py - float(hip[1])) <= reach_m
    if side is not None and p.own_side_m is not None:
        bx, by, sx, sy = (float(v) for v in side)
        ok &= (px - bx) * sx + (py - by) * sy >= own_side(p)
    cells = np.column_stack([px[ok], py[ok]])
    return cells, np.asarray(lab[ci, cj][ok], dtype=np.int32), (dist + p.w_height * dz)[ok]


def shin_cost_region(
    view: TerrainView,
    world: TerrainWorld,
    leg: int,
    hip_xy: NDArray[np.float64],
    nom: NDArray[np.float64],
    z_ref: float,
    keep_xy: NDArray[np.float64] | None,
    flying: bool,
    side: NDArray[np.float64] | None,
    label: int,
    poly: ConvexRegion,
    p: DecisionParams,
    cache: dict[tuple[int, int, int], ConvexRegion | None] | None = None,
    kept_ok: bool = False,
) -> tuple[int, ConvexRegion, NDArray[np.float64] | None]:
    """The shin test in the region cost (DecisionParams.shin_region_cost_m): gives the region, polygon and held
    place (3,) of a next touchdown of leg `leg` (hip at hip_xy (2,) at touchdown, nominal foothold nom (2,)), given
    the region and polygon chosen for it (label, poly): those and no held place when a place of the polygon along
    the heading clears the shin (leg_bounds_found) or none of the cells _shin_cells gives (the height reference
    z_ref, the reach, the side (4,) as the first choice) is shin_choice's (its shin term shin_cell_cost; keep_xy
    (2,): the choice made before, kept_ok: its shin cleared; flying: the foot in the air, which only keeps that
    choice); else that cell's
    region, its polygon grown around the cell, and the cell (its ground height), where the foothold is held."""
    if p.shin_region_cost_m is None or view.l_upper_m <= 0.0 or view.l_lower_m <= 0.0:
        return label, poly, None
    maps, regions = world.maps, world.regions
    if leg_bounds_found(view, maps, leg, hip_xy, nom, poly, p)[1]:
        return label, poly, None
    if flying and kept_ok and keep_xy is not None:
        # in the air, a choice made where the shin cleared stands while it lies on a region (its reach and side
        # as choose_region's kept region in the air)
        kept = regions.label_at(float(keep_xy[0]), float(keep_xy[1]))
        if kept:
            q = _polygon(regions, kept, keep_xy, p, {} if cache is None else cache)
            if q is not None:
                z = float(maps.height_at(float(keep_xy[0]), float(keep_xy[1])))
                return kept, q, np.array([float(keep_xy[0]), float(keep_xy[1]), z])
    cells, labs, base = _shin_cells(regions, maps, nom, z_ref, p, hip_xy, reach_xy(view, p), side)
    if cells.shape[0] == 0:
        return label, poly, None
    p_cells = dataclasses.replace(p, shin_rule=p.shin_region_rule)
    clear, within = leg_clearance(view, maps, leg, hip_xy, cells, p_cells)
    shin = shin_cell_cost(clear, within, shin_needed(p_cells), float(p.shin_region_cost_m))
    if not p.shin_region_same:
        # the chosen region's places do not clear (leg_bounds_found): its cells pay the shin term, the choice is
        # another region's (a box's or the platform's top) or none
        shin[labs == label] = float(p.shin_region_cost_m)
    keep = None
    if keep_xy is not None:
        near = np.hypot(cells[:, 0] - float(keep_xy[0]), cells[:, 1] - float(keep_xy[1]))
        k = int(np.argmin(near))
        keep = k if float(near[k]) <= 0.75 * regions.resolution_m else None
    i = shin_choice(base, shin, keep, p.keep_m, flying, kept_ok)
    if i < 0:
        return label, poly, None
    cell = cells[i]
    hold = np.array([cell[0], cell[1], float(maps.height_at(float(cell[0]), float(cell[1])))])
    if int(labs[i]) == label and bool(poly.contains(cell[None, :], 1e-6)[0]):
        return label, poly, hold
    q = _polygon(regions, int(labs[i]), cell, p, {} if cache is None else cache)
    return (int(labs[i]), q, hold) if q is not None else (label, poly, hold)


HOLD_HALF_M = 0.005  # a held touchdown's square in the step QP (half side, m): it stays where it is held


def held_foothold(
    view: TerrainView, leg: int, kept: NDArray[np.float64] | None = None
) -> NDArray[np.float64] | None:
    """Gives where a next touchdown of leg `leg` with no region goes (3,): where the foot stands if it is in stance
    (ground it is standing on: a step in place); in the air, its kept choice for this touchdown (kept (3,), chosen
    on a region; None: none, and the foot keeps its nominal)."""
    if bool(view.stance[leg]):
        q = np.asarray(view.p_world_foot[leg], dtype=np.float64).copy()
        q[2] -= view.foot_radius_m
        return q
    if kept is not None and bool(np.all(np.isfinite(kept))):
        return np.asarray(kept, dtype=np.float64).copy()
    return None


def _square_rows(xy: NDArray[np.float64], half_m: float) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Gives the half-planes (A, b) of the square of half side half_m around xy (2,)."""
    A = np.array([[1.0, 0.0], [-1.0, 0.0], [0.0, 1.0], [0.0, -1.0]])
    x, y = float(xy[0]), float(xy[1])
    return A, np.array([x + half_m, half_m - x, y + half_m, half_m - y])


def step_request(
    view: TerrainView, path: StepPath, order: NDArray[np.intp], hip_height_m: float
) -> StepRequest | None:
    """Gives the step QP's request for the path's touchdowns `order` (nominal = the selected footholds); None
    when they are not every leg once per 4 slots."""
    legs = path.leg[order].astype(np.intp)
    K = legs.size
    legs_l = legs.tolist()
    if any(legs_l[k] != legs_l[k - 4] for k in range(4, K)) or sorted(legs_l[:4]) != [0, 1, 2, 3]:
        return None
    t_now = view.t_s
    t_td = path.t_touchdown[order] - t_now
    # (on Python floats: the same arithmetic, one slot at a time)
    td_l = t_td.tolist()
    lift_l = path.t_liftoff.tolist()
    lift_now_l = path.t_liftoff_now.tolist()
    t_lo = np.empty(K)
    last: dict[int, int] = {}  # each leg's latest slot so far (an index into the path)
    for j, k in enumerate(order.tolist()):
        leg = legs_l[j]
        if leg in last:
            t_lo[j] = lift_l[last[leg]] - t_now
        else:
            lo = lift_now_l[leg]
            t_lo[j] = -1.0 if math.isnan(lo) else min(lo - t_now, td_l[j] - 1e-3)
        last[leg] = k
    body = path.body
    t_abs = path.t_touchdown[order]
    abs_l = t_abs.tolist()
    later = np.array([min([u for u in abs_l if u > t + 1e-6], default=t + 0.2) for t in abs_l])
    t_mid = 0.5 * (t_abs + later)
    p_hip = body.position(t_abs) + rotate_yaw(body.yaw(t_abs), view.p_body_hip[legs])
    return StepRequest(
        legs=legs,
        t_liftoff=t_lo,
        t_touchdown=np.maximum(t_td, 1e-3),
        p_nominal=path.p_world_touchdown[order, :2].copy(),
        p_hip=p_hip,
        hip_height=np.full(K, hip_height_m),
        c_body=body.position(t_mid),
        yaw_body=np.asarray(body.yaw(t_mid), dtype=np.float64),
        p_feet=view.p_world_foot[:, :2].copy(),
        v_feet=view.v_world_foot[:, :2].copy(),
        t_now=float(t_now),
    )


def path_holds(rest_clearance_m: float, planned_clearance_m: float, worse_m: float | None) -> bool:
    """Gives whether a body path is kept until its next due replan: the rest of it ahead of the body sweeps no
    deeper into a body obstacle than 0, or, for a path that already came within worse_m of one when planned, than
    worse_m below the clearance it had then (worse_m: DecisionParams.path_worse_m; None: 0 always)."""
    floor = 0.0 if worse_m is None else min(0.0, planned_clearance_m - worse_m)
    return rest_clearance_m >= floor


def pitched_nominals(view: TerrainView, path: StepPath) -> StepPath:
    """Gives the path with each nominal foothold moved along the heading to under its hip as the body's pitch
    target places it (the step selection puts the hips at their level offsets: pitched 30° with the stairs, a hind
    hip stands 4 cm further forward and a front one 4 cm further back than that)."""
    if path.n_touchdowns == 0 or view.pitch_rad == 0.0:
        return path
    u = np.array([math.cos(view.yaw), math.sin(view.yaw)])
    dx = view.p_body_hip[path.leg.astype(np.intp), 0] * (math.cos(view.pitch_rad) - 1.0)
    p = path.p_world_touchdown.copy()
    p[:, :2] += dx[:, None] * u[None, :]
    return path.with_touchdowns(p, path.kind)


def choose_footholds(
    view: TerrainView,
    path: StepPath,
    world: TerrainWorld,
    memory: FootholdMemory,
    qp: StepQP,
    params: DecisionParams,
    polygon_cache: dict[tuple[int, int, int], ConvexRegion | None] | None = None,
) -> FootholdDecision:
    """Gives the footholds of the path's next K touchdowns: a region each, a polygon of it around the nominal
    foothold, the step QP inside those polygons (see the module docstring). qp holds the warm start;
    polygon_cache (keyed by region and nominal cell, valid for one regions object) saves regrowing polygons."""
    p = params
    maps, regions = world.maps, world.regions
    K = qp.K
    path = pitched_nominals(view, path)
    p_new = path.p_world_touchdown.copy()
    z_stance = memory.z_stance.copy()
    feet_z = view.p_world_foot[:, 2] - view.foot_radius_m
    z_stance[view.stance] = feet_z[view.stance]
    z_stance = np.where(np.isfinite(z_stance), z_stance, feet_z)
    t_td_next, _ = path.next_touchdowns()
    mem_t = np.full(4, np.nan)
    mem_p = np.full((4, 3), np.nan)
    mem_on = np.ones(4, dtype=bool)
    empty = FootholdDecision(p_new, (), None, 0.0, FootholdMemory(mem_t, mem_p, z_stance, mem_on))
    if path.n_touchdowns < K:
        return empty
    order = np.lexsort((path.leg, path.t_touchdown))[:K]
    legs = path.leg[order].astype(np.intp)
    same = np.abs(memory.t_touchdown - t_td_next) < 0.15
    z_ref = z_stance.copy()
    cache = {} if polygon_cache is None else polygon_cache
    t_abs = path.t_touchdown[order]
    bodies = path.body.position(t_abs)[:, :2]
    yaws = np.asarray(path.body.yaw(t_abs), dtype=np.float64).reshape(-1)
    hips = bodies + rotate_yaw(yaws, view.p_body_hip[legs])
    # each slot's body centre at touchdown and the unit vector toward its leg's side (own_side_m)
    outward = np.zeros((K, 2))
    outward[:, 1] = np.where(view.p_body_hip[legs, 1] >= 0.0, 1.0, -1.0)
    sides = np.hstack([bodies, rotate_yaw(yaws, outward)])
    reach = reach_xy(view, p)
    lost = np.zeros(K, dtype=bool)
    held_at: dict[int, NDArray[np.float64]] = {}
    shin_held: set[int] = set()  # slots held where their shin clears (DecisionParams.shin_region_cost_m)
    # per leg, as Python bools: the remembered choice is of this touchdown (same) and complete (finite)
    held_l = (same & np.all(np.isfinite(memory.p_chosen), axis=1)).tolist()
    stance_l = view.stance.tolist()
    legs_l = legs.tolist()
    # In strides of four slots (one per leg: a stride's choices do not depend on each other), the regions of a
    # stride's slots chosen at once (_choose_regions: choose_region's answers), then their polygons in slot order.
    order_l = order.tolist()
    polys: list[ConvexRegion | None] = [None] * K
    for g0 in range(0, K, 4):
        group = list(range(g0, min(g0 + 4, K)))
        if len({legs_l[j] for j in group}) < len(group):
            group_sets = [[j] for j in group]  # a leg twice in a stride: one slot at a time
        else:
            group_sets = [group]
        for gs in group_sets:
            asked: list[tuple[int, NDArray[np.float64] | None, bool]] = []
            for j in gs:
                leg = legs_l[j]
                first = j < 4
                keep = memory.p_chosen[leg, :2] if first and held_l[leg] else None
                was_on = memory.on_region is None or bool(memory.on_region[leg])
                if keep is not None and was_on and lost_region(regions, maps, memory.p_chosen[leg], p):
                    lost[j] = True
                    z_ref[leg] = float(memory.p_chosen[leg, 2])
                    continue
                asked.append((j, keep, first and not stance_l[leg]))
            if not asked:
                continue
            labels = _choose_regions(
                regions,
                maps,
                path.p_world_touchdown[[order_l[j] for j, _, _ in asked], :2],
                [float(z_ref[legs_l[j]]) for j, _, _ in asked],
                [keep for _, keep, _ in asked],
                p,
                [flying for _, _, flying in asked],
                hips[[j for j, _, _ in asked]],
                reach,
                sides[[j for j, _, _ in asked]],
            )
            for (j, keep, flying), label in zip(asked, labels, strict=True):
                leg = legs_l[j]
                nom = path.p_world_touchdown[order_l[j], :2]
                if not label and np.isfinite(reach):
                    # no region within the leg's reach: the nearest one beyond it (a long step onto a stone)
                    label = choose_region(
                        regions, maps, nom, float(z_ref[leg]), keep, p, flying, side=sides[j]
                    )
                poly = None
                if label:
                    late = flying and float(path.t_touchdown[order_l[j]]) - view.t_s < p.flight_piece_s
                    poly = _polygon(regions, label, _piece_centre(regions, label, nom, keep, late), p, cache)
                if poly is not None and j < 4 and p.shin_regions > 1 and not flying:
                    # a region none of whose places clears the shin: the next region that has one (a foot in
                    # stance; in the air it keeps the region it lifted off for: no switch late in a swing)
                    label, poly = shin_region(
                        view,
                        world,
                        leg,
                        hips[j],
                        nom,
                        float(z_ref[leg]),
                        keep,
                        flying,
                        sides[j],
                        label,
                        poly,
                        p,
                        cache,
                    )
                if poly is not None and j < 4 and p.shin_region_cost_m is not None:
                    # no place of the polygon clears the shin: the reachable cell of least cost with the shin in
                    # it, and a polygon around it (a low box's top or the floor before it, behind a nominal past
                    # it), where the foothold is held; in the air, the choice made so
                    label, poly, shin_at = shin_cost_region(
                        view,
                        world,
                        leg,
                        hips[j],
                        nom,
                        float(z_ref[leg]),
                        keep,
                        flying,
                        sides[j],
                        label,
                        poly,
                        p,
                        cache,
                        memory.shin_ok is not None and bool(memory.shin_ok[leg]),
                    )
                    if shin_at is not None:
                        held_at[j] = shin_at
                        shin_held.add(j)
                if poly is None and j < 4:
                    # no region at all: a foot in stance steps in place, one in the air keeps its choice made on a
                    # region, not its nominal place over a gap or a pit
                    was_on = memory.on_region is None or bool(memory.on_region[leg])
                    hold = held_foothold(
                        view, leg, memory.p_chosen[leg] if keep is not None and was_on else None
                    )
                    if hold is not None:
                        held_at[j] = hold
                        z_ref[leg] = float(hold[2])
                polys[j] = poly
                if j in shin_held:
                    z_ref[legs_l[j]] = float(held_at[j][2])
                elif poly is not None:
                    z_ref[legs_l[j]] = float(poly.height_at(poly.project(nom)))
    # Each polygon of the next touchdowns with its bounds along the heading (the shin clear of edges behind the
    # foot, the hip in reach).
    # (leg_bounds' first test, the shin and the reach at each polygon's place nearest the nominal foothold, for the
    # first four slots in one evaluation: most pass it, and leg_bounds then has nothing to add)
    first4 = [(j, q) for j, q in enumerate(polys[:4]) if q is not None]
    passed: set[int] = set()
    if first4 and view.l_upper_m > 0.0 and view.l_lower_m > 0.0:
        slots = [j for j, _ in first4]
        bases = np.array([q.project(path.p_world_touchdown[order[j], :2]) for j, q in first4])
        z_hips = np.array([hip_height(view, legs_l[j]) for j in slots])
        clear0, within0 = _clearance(view, maps, z_hips, hips[slots], bases, p, np.asarray(legs)[slots])
        ok0 = ((clear0 >= shin_needed(p)) & within0).tolist()
        passed = {j for j, ok in zip(slots, ok0, strict=True) if ok}
    rows: list[tuple[NDArray[np.float64], NDArray[np.float64]] | None] = []
    # each leg's next foothold chosen where its shin clears (FootholdMemory.shin_ok)
    shin_ok = np.zeros(4, dtype=bool)
    for j in passed | shin_held:
        shin_ok[legs_l[j]] = True
    for j, (q, k) in enumerate(zip(polys, order, strict=True)):
        if j in held_at:
            rows.append(_square_rows(held_at[j][:2], HOLD_HALF_M))
            continue
        if q is None:
            rows.append(None)
            continue
        bounds: list[tuple[NDArray[np.float64], float]] = []
        if j < 4 and j not in passed:
            bounds, found = leg_bounds_found(
                view, maps, legs_l[j], hips[j], path.p_world_touchdown[k, :2], q, p
            )
            leg = legs_l[j]
            was_on = memory.on_region is None or bool(memory.on_region[leg])
            kept_ok = memory.shin_ok is not None and bool(memory.shin_ok[leg])
            shin_ok[leg] = found
            if not found and p.shin_hold and not stance_l[leg] and held_l[leg] and was_on and kept_ok:
                # no place of this polygon clears the shin: this touchdown keeps its choice made earlier (see
                # DecisionParams.shin_hold)
                held_at[j] = memory.p_chosen[leg].copy()
                shin_ok[leg] = True
                rows.append(_square_rows(held_at[j][:2], HOLD_HALF_M))
                continue
        if not bounds:
            rows.append((q.A, q.b))
        else:
            rows.append(
                (
                    np.vstack([q.A, *[a[None, :] for a, _ in bounds]]),
                    np.append(q.b, [b for _, b in bounds]),
                )
            )
    # Every nominal foothold already inside its polygon: the region rows are inactive, the selection stands.
    inside = all(
        r is None or bool(np.all(r[0] @ path.p_world_touchdown[k, :2] <= r[1] - p.inside_margin_m))
        for r, k in zip(rows, order, strict=True)
    )
    req = None if inside else step_request(view, path, order, view.height_m)
    plan = None
    if req is not None:
        plan = qp.solve(req, maps, rows)
        if not np.all(np.isfinite(plan.footholds)):
            plan = None
    t_rel = (path.t_touchdown[order] - view.t_s).tolist()
    shift = 0.0
    back = 0.0
    late_holds = 0
    # an answer with a hard family softened, or one OSQP did not solve to its tolerance, is no sound plan
    plan_sound = plan is not None and not plan.hard_softened and plan.status == "solved"
    ux, uy = math.cos(view.yaw), math.sin(view.yaw)
    for j, k in enumerate(order):
        leg = legs_l[j]
        held = j < 4 and held_l[leg]
        # an unsound answer due soon (see DecisionParams.late_jump_s)
        late = held and not plan_sound and plan is not None and j not in held_at
        late = late and p.late_jump_s is not None and t_rel[j] < p.late_jump_s
        if late:
            assert plan is not None
            dx, dy = (plan.footholds[j, :2] - memory.p_chosen[leg, :2]).tolist()
            # (held only while the kept foothold is still on this slot's polygon: a place the new maps reject moves)
            q = polys[j]
            far = dx * dx + dy * dy > p.late_jump_m * p.late_jump_m
            late = far and q is not None and bool(q.contains(memory.p_chosen[leg, :2], 1e-3))
        late_holds += int(late and not (t_rel[j] < p.freeze_s or lost[j]))
        if (t_rel[j] < p.freeze_s and held) or lost[j] or late:
            p_new[k] = memory.p_chosen[leg]
            if j < 4:
                shin_ok[leg] = memory.shin_ok is not None and bool(memory.shin_ok[leg])
        elif j in held_at:
            p_new[k] = held_at[j]
        elif plan is not None:
            x, y = plan.footholds[j, :2].tolist()
            p_new[k, 0], p_new[k, 1] = x, y
            p_new[k, 2] = float(maps.height_at(x, y))
        if j < 4:
            # on Python floats: the move off the nominal, along the heading (a dot of two) and across it
            mx, my = (p_new[k, :2] - path.p_world_touchdown[k, :2]).tolist()
            along = mx * ux + my * uy
            ahead = max(0.0, along) if not p.shift_counts_ahead else 0.0
            rx, ry = mx - ahead * ux, my - ahead * uy
            shift = max(shift, math.sqrt(rx * rx + ry * ry))
            back += max(0.0, -along) / 4.0
            mem_t[leg] = float(path.t_touchdown[k])
            mem_p[leg] = p_new[k]
            mem_on[leg] = polys[j] is not None or bool(lost[j]) or j in held_at
    return FootholdDecision(
        p_new,
        tuple(polys),
        plan,
        shift,
        FootholdMemory(mem_t, mem_p, z_stance, mem_on, shin_ok),
        back,
        path.t_liftoff_now.copy(),
        late_holds,
    )


# ---- the stack the controller calls ------------------------------------------------------------------------------


@dataclass(frozen=True)
class PipelineParams:
    """The unified terrain pipeline. use_sensor: maps from the depth sensor (False: the scene's ground truth,
    re-centred on the body every truth_recenter_m); perception_rate_hz: scans (maps and regions) a second; swing:
    what the pipeline's walk changes in the swing planner's parameters (SwingParams fields), the same on every
    terrain (see TerrainSwing); maps: what the pipeline changes in perception.maps (MapParams fields, the same on
    every terrain, see _regions_maps); replan_height_from_plan_m: HandlerParams.replan_height_from_plan_m while walking
    on the pipeline (a swing within this of its plan's height is replanned from the plan's height, m); stop: a steered
    walk (no goal) stops short of body obstacles (planning.terrain.steering, the body path's footprint); barrier: a
    walk to a goal keeps its footprint with the legs (robot_footprint's circles, no margin) off body obstacles by
    its command (planning.terrain.steering.barrier_command; on by default, BarrierParams.margin_m);
    footprint_from_robot, footprint_circles, footprint_margin_m: the body path's footprint is footprint_circles
    circles along the body covering the robot's planform with its legs, grown by footprint_margin_m (m), in place
    of path's footprint_x_m and footprint_r_m (robot_footprint); swing_rate_hz: see below. Footprint off: on the
    clutter quick spec it gave 6 of 12 clean (8 circles, no margin; 4 circles and 2 cm: 0 of the first 6) against 7
    without (docs/terrain-notes.md): the hind knees kept off the tall boxes, but the wider body took routes nearer
    the low boxes and fell on them."""

    use_sensor: bool = True
    truth_half_extent_m: float = 2.5
    truth_recenter_m: float = 0.8
    perception_rate_hz: float = 10.0
    perception: PerceptionParams = field(default_factory=PerceptionParams)
    maps: dict[str, Any] = field(default_factory=lambda: _regions_maps())
    path: BodyPathParams = field(default_factory=BodyPathParams)
    decision: DecisionParams = field(default_factory=DecisionParams)
    step_qp: StepQPParams = field(default_factory=lambda: _regions_qp())
    swing: TerrainSwing = field(default_factory=lambda: TerrainSwing())
    replan_height_from_plan_m: float = 0.03
    stop: StopParams = field(default_factory=StopParams)
    barrier: BarrierParams = field(default_factory=BarrierParams)
    footprint_from_robot: bool = False
    footprint_circles: int = 8
    footprint_margin_m: float = 0.0
    # The swing replanning's rate while walking on the pipeline (Hz; by default the walk's own, WalkParams.
    # swing_rate_hz, every 3 ms): swing replanning is ~25 % of the regions walk's CPU. 250 (every 4 ms) together with
    # perception_rate_hz 7.5 and SensorParams.dense_spacing_m 0.03 / VoxelParams.carve_every 3 took ~6-10 % off the
    # walk's CPU but crossed fewer quick-spec draws than main (stairs 1 of 4 against 3, clutter 1 of 5 against 3;
    # docs/terrain-notes.md, "Session 9: terrain speed"): kept at the walk's rate.
    swing_rate_hz: float = 1000.0 / 3.0


def robot_planform(robot: Any) -> tuple[float, float, float]:
    """Gives the robot's planform in its standing pose, in the body frame: (x_min, x_max, half_width) m, the
    horizontal extent of every collision geom of the robot (the trunk, and the legs: a knee that points back sticks
    out behind the trunk, a thigh beside it), each geom by its axis-aligned box."""
    m = robot.model
    d = mujoco.MjData(m)
    d.qpos[:] = robot.home_qpos()
    mujoco.mj_forward(m, d)
    base = d.xpos[robot.body_id]
    ground = {int(mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_GEOM, n)) for n in robot.ground_geom_names}
    lo = np.full(2, np.inf)
    hi = np.full(2, -np.inf)
    for g in range(m.ngeom):
        if int(m.geom_bodyid[g]) == 0 or g in ground or not (m.geom_contype[g] or m.geom_conaffinity[g]):
            continue
        R = d.geom_xmat[g].reshape(3, 3)
        c = d.geom_xpos[g] + R @ m.geom_aabb[g, :3] - base
        half = np.abs(R) @ m.geom_aabb[g, 3:]
        lo = np.minimum(lo, c[:2] - half[:2])
        hi = np.maximum(hi, c[:2] + half[:2])
    return float(lo[0]), float(hi[0]), float(max(-lo[1], hi[1]))


def robot_footprint(robot: Any, params: PipelineParams, path: BodyPathParams) -> BodyPathParams:
    """Gives the body path's parameters with its footprint from the robot (footprint_from_robot): footprint_circles
    circles along the body's x axis, evenly spaced, whose union covers the planform (robot_planform) grown by
    footprint_margin_m: the legs as well as the trunk (a tall box passed beside the body meets a hind knee 0.52 m
    behind Spot's centre and 0.2 m to its side, outside the trunk's circles)."""
    if not params.footprint_from_robot:
        return path
    n = params.footprint_circles
    if n < 1:
        raise ValueError(f"PipelineParams.footprint_circles: must be at least 1, got {n}")
    x0, x1, w = robot_planform(robot)
    e = params.footprint_margin_m
    x0, x1, w = x0 - e, x1 + e, w + e
    s = (x1 - x0) / n
    xs = tuple(float(x0 + s * (k + 0.5)) for k in range(n))
    return dataclasses.replace(path, footprint_x_m=xs, footprint_r_m=float(math.hypot(w, s / 2.0)))


@dataclass(frozen=True)
class TerrainSwing:
    """The swing planner on the pipeline's walk, one set on every terrain (SwingParams' fields of the same names):
    a late foot high above its touchdown comes down faster (late_descent_gain_per_s); a step up over an edge rises
    first, from a wait point fixed at lift-off and as high as the leg reaches (rise_first_*), rise_first_margin_m
    over the edge; vertical accelerations at most a_max_z_mps2 (the gentleness family scaled to keep its
    fractions of it); edges above the foot probed at cliff_rings_m with cliff_margin_m; no extra apex over an
    obstacle (apex_free_over_obstacles). The apex keeps the planner's own cap over the highest ground on the way
    (SwingParams.terrain_apex_m, 0.10 m; this set had turned it off, unmeasured): a foot stepping down off the mixed
    family's top landing rose 16 cm over it and was still high at its touchdown time. Neutral on the families
    (with the cap against without, same draws: mixed 39 and 31 from 1 mm forward against 38 and 34, stairs 34
    against 33, clutter 32 against 32, stones 46 against 44; docs/terrain-notes.md, session 28). Off
    (measured on the clutter quick spec against main at 06fdc87: 6 of 12 clean with them, 9 without, the same 4
    no-step touchdowns; docs/terrain-notes.md): a swing whose plan meets the terrain planned again with its apex free
    of its first plan's, and still colliding, rising first over the box on its way (rise_over_boxes: clutter seed
    848, the foothold moved 28 cm across a 9 cm box 20 ms after lift-off, the apex stayed the first plan's over the
    floor, and the foot met the box's top edge);
    the ground within 1 cm of the lift-off and the touchdown points is judged as where the foot stands
    (endpoint_zone_m: clutter seed 190, every candidate was a terrain collision at its touchdown sample, 4 mm under
    the dilated noisy floor, and the box on the way went unjudged).
    liftoff_clear_run_m, liftoff_clear_margin_m: a swing that lifts off beside a box (ground within its route's
    first liftoff_clear_run_m above the lift-off height by more than rise_first_above_m) rises first, where it is,
    to liftoff_clear_margin_m over the highest ground on its route: the clutter family 29 of 50 clean against 22
    without (8 gains, 1 loss; no-step touchdowns 24 -> 3), stones quick unchanged (docs/terrain-notes.md, session
    12; 0.10 m and 0.03 m measured 22 of 50: more swings lifted, higher, and lower legs met the boxes they rose
    beside as they came down)."""

    late_descent_gain_per_s: float = 5.0
    a_max_z_mps2: float = 40.0
    apex_free_over_obstacles: bool = False
    cliff_margin_m: float = 0.03
    cliff_rings_m: tuple[float, ...] = (0.01, 0.02, 0.03)
    rise_first_margin_m: float = 0.05
    rise_first_gap_m: float = 0.08
    rise_first_anchored: bool = True
    rise_first_within_reach: bool = True
    rise_over_boxes: bool = False
    endpoint_zone_m: float | None = None
    liftoff_clear_run_m: float = 0.05
    liftoff_clear_margin_m: float = 0.02

    def applied_to(self, sp: SwingParams) -> SwingParams:
        """Gives sp with these fields set, its gentleness family's accelerations kept at the same m/s²."""
        scale = sp.a_max_z_mps2 / self.a_max_z_mps2
        family = tuple(dataclasses.replace(v, accel_frac=v.accel_frac * scale) for v in sp.vertical_family)
        fields = {f.name: getattr(self, f.name) for f in dataclasses.fields(self)}
        return dataclasses.replace(sp, vertical_family=family, **fields)


def _regions_maps() -> dict[str, Any]:
    """The pipeline's map settings (MapParams fields over perception.maps): the dense-obstacle rule does not count
    cells that are step obstacles only for standing higher than max_step_height_m above the lowest ground nearby
    (dense_counts_high False). With the sensor a stone 0.318 m above its pit is such a cell by cell against the 0.32 m
    limit, the whole stone turned into a body obstacle, and the body path swerved around it (stones seed 1: 114
    body-obstacle cells at 2.5 s, 5 with this); the body passes over a stone. Nor are such cells step obstacles
    (high_is_step False): the region choice bounds each step's rise from the leg's own last foothold (max_rise_m),
    and the rule took a band low_radius_m wide off the regions along a flight's open side (more than
    max_step_height_m above the floor beside it), where the feet of a body walking off the flight's centre line
    stand. Nor does the step map close no-step gaps as wide as min_support_m (min_support_m 0: one cell): the
    regions are inset by the foot radius and an edge margin, which leaves out a patch too small for a foot, while
    the closing (a disk of 7 cells, 0.21 m at 3 cm cells, for 0.16 m) took a steep flight's whole tread off the map
    wherever its clear part, between the bands at its riser and its nosing, came out 7 cells wide.
    The body band starts above the ground the robot stands on as well as above each cell's own (band_from_support):
    the pit in the 4-10 cm slot between a left and a right stone holds the stones' top edges 0.3 m above its floor,
    inside the band measured from the pit, and those few cells swung the body path 0.3-0.6 m aside onto the outer
    stones' edges (stones draw 3: body path to y -0.4…-0.6, a foot in the pit at 9.1 s; straight with this)."""
    return {
        "dense_counts_high": False,
        "high_is_step": False,
        "min_support_m": 0.0,
        "band_from_support": True,
    }


# DecisionParams.back_drop_frac when a walk goes down descents backward (WalkCommand.descend_backward): a fall of
# 0.2 of the leg's length (Spot 0.13 m; the clutter family's 0.12 m platform is stepped off forward)
BACK_DROP_FRAC = 0.2


def _regions_qp() -> StepQPParams:
    """The step QP of the regions pipeline: room for a polygon's half-planes per slot, and a region's rows (the
    step_keep family) harder than reach: a foot goes to its region even where its reachable rectangle, an estimate
    from its speed now, says it is late; a front and a hind foot may share a stone (15 cm apart along the body,
    not 25); at most 400 OSQP iterations (warm-started each tick: a conflicted replan stops early, not at 4000);
    no margin pull beyond the polygon (margin_m = keep_clearance_m): the polygon is already inset by the foot's
    radius and the edge margin, and the QP's 4 cm pull on top left 7 cm of a 30 cm stair tread, moving every
    foothold ~10 cm off its nominal place (measured: the stairs climb rolled over with it and crossed without);
    a swinging foot's reachable rectangle from a foot acceleration of 200 m/s², not 40: at 40 a foot rising first
    over a riser, fast forward late in its swing, had its target pushed 6-12 cm further on in its last 60 ms (the
    rectangle p0 + v0 T ± a T²/2 is narrow then), and the diagonal pair it landed in, 80 cm long, rolled the body
    over on every stairs climb; the swing planner brakes the foot instead."""
    w = list(StepQPParams().weights)
    w[2] = 3e4
    return StepQPParams(
        max_foot_accel=200.0,
        keep_planes=14,
        weights=tuple(w),
        self_longitudinal_m=0.15,
        max_iter=400,
        margin_m=StepQPParams().keep_clearance_m,
    )


def _p(values: list[float], q: float) -> float | None:
    return None if not values else round(float(np.percentile(values, q)), 3)


@dataclass
class PipelineStats:
    """What the pipeline did in a run (the run report's `navigator` section)."""

    scans: int = 0
    body_paths: int = 0
    qp_solves: int = 0
    qp_ms: list[float] = field(default_factory=list)
    qp_bare_ms: list[float] = field(default_factory=list)
    perception_ms: list[float] = field(default_factory=list)
    regions_ms: list[float] = field(default_factory=list)
    footholds_ms: list[float] = field(default_factory=list)
    gait_switches: int = 0
    barrier_ticks: int = 0
    slow_waits: int = 0
    late_holds: int = 0
    min_height_m: float = np.inf
    backward_s: float = 0.0
    turns_given_up: int = 0

    def summary(self) -> dict[str, Any]:
        return {
            "pipeline": "regions",
            "scans": self.scans,
            "body_paths": self.body_paths,
            "step_qp_solves": self.qp_solves,
            "step_qp_ms_p50": _p(self.qp_ms, 50),
            "step_qp_ms_p99": _p(self.qp_ms, 99),
            "step_qp_bare_solver_ms_p50": _p(self.qp_bare_ms, 50),
            "step_qp_bare_solver_ms_p99": _p(self.qp_bare_ms, 99),
            "perception_ms_p50": _p(self.perception_ms, 50),
            "perception_ms_p99": _p(self.perception_ms, 99),
            "regions_ms_p50": _p(self.regions_ms, 50),
            "footholds_ms_p50": _p(self.footholds_ms, 50),
            "footholds_ms_p99": _p(self.footholds_ms, 99),
            "gait_switches": self.gait_switches,
            "barrier_ticks": self.barrier_ticks,
            "slow_gait_waits": self.slow_waits,
            "late_jump_holds": self.late_holds,
            "backward_s": round(self.backward_s, 2),
            "turns_given_up": self.turns_given_up,
            "min_body_height_target_m": None
            if not np.isfinite(self.min_height_m)
            else round(self.min_height_m, 3),
        }


class TerrainPipeline:
    """The unified terrain stack a WalkController calls (``WalkController.use_terrain``): `perceive` and
    `plan_path` at their rates, `decide` and `footholds` every step-plan tick. It never writes into the controller."""

    def __init__(
        self,
        robot: Any,
        model: mujoco.MjModel,
        data: mujoco.MjData,
        goal_xy: tuple[float, float] | None,
        scene: TerrainScene | None = None,
        params: PipelineParams | None = None,
        body: str = "trunk",
    ) -> None:
        self.params = p = params or PipelineParams()
        if goal_xy is not None and not np.all(np.isfinite(goal_xy)):
            raise ValueError(f"TerrainPipeline.goal_xy: must be finite, got {goal_xy}")
        if not p.use_sensor and scene is None:
            raise ValueError("TerrainPipeline: use_sensor=False needs the scene (ground-truth maps)")
        self.robot = robot
        self.data = data
        self.scene = scene
        self.goal = None if goal_xy is None else np.asarray(goal_xy, dtype=np.float64).reshape(2)
        self.decision_params = dataclasses.replace(
            p.decision,
            regions=dataclasses.replace(p.decision.regions, foot_radius_m=float(robot.foot_radius_m)),
        )
        if self.decision_params.regions.max_planes + 6 > p.step_qp.keep_planes:
            raise ValueError(
                "PipelineParams: step_qp.keep_planes must hold a region's polygon (regions.max_planes + 4 edges)"
                " and its two bounds along the heading"
            )
        perception = dataclasses.replace(p.perception, maps=dataclasses.replace(p.perception.maps, **p.maps))
        self.perception = Perception(model, body, perception) if p.use_sensor else None
        self.qp = StepQP(p.step_qp)
        self.path_params = robot_footprint(robot, p, p.path)
        self.barrier_footprint = robot_footprint(
            robot, dataclasses.replace(p, footprint_from_robot=True, footprint_margin_m=0.0), p.path
        )
        # a turn round needs room by the barrier's own footprint and margin (+1 cm), or the barrier stops it midway
        self.decision_params = dataclasses.replace(
            self.decision_params,
            turn_circles_x_m=tuple(self.barrier_footprint.footprint_x_m),
            turn_circle_r_m=float(self.barrier_footprint.footprint_r_m),
            turn_margin_m=(p.barrier.margin_m or 0.0) + 0.01,
        )
        self.overhangs = OverhangMemory()
        self.world: TerrainWorld | None = None
        self.path: BodyPath | None = None
        self.memory = FootholdMemory.empty()
        self.last: FootholdDecision | None = None
        self.facing: Facing = "forward"
        self.may_turn = True  # False once a turn round was given up (DecisionParams.turn_timeout_s)
        self._turn_t0: float | None = None  # when the turn round under way began (None: none, or done)
        self.stats = PipelineStats()
        self._polygons: dict[tuple[int, int, int], ConvexRegion | None] = {}
        self._truth_center: NDArray[np.float64] | None = None
        self._truth_maps: TerrainMaps | None = None
        self._t_path = -np.inf
        self._scan_xy = np.zeros(2)
        self._overlay_maps: TerrainMaps | None = None
        self._overlay_outlines: dict[str, dict[str, Any]] = {}

    @property
    def maps(self) -> TerrainMaps | None:
        return None if self.world is None else self.world.maps

    def perceive(self, p_world_body: NDArray[np.float64]) -> None:
        """Scans (or re-centres the ground-truth maps) and segments the regions."""
        import time

        p = self.params
        t0 = time.perf_counter()
        if self.perception is not None:
            maps = self.perception.scan_now(self.data)
        else:
            xy = p_world_body[:2]
            if self._truth_center is None or np.linalg.norm(xy - self._truth_center) > p.truth_recenter_m:
                assert self.scene is not None
                self._truth_center = np.array(xy, dtype=np.float64)
                self._truth_maps = maps_from_scene(
                    self.scene, (float(xy[0]), float(xy[1])), p.truth_half_extent_m
                )
            assert self._truth_maps is not None
            maps = self._truth_maps
        xy0 = (float(p_world_body[0]), float(p_world_body[1]))
        regions = segment_regions(maps, self.decision_params.regions, cover=False, view_xy=xy0)
        ground = swing_ground(
            maps, self.decision_params.regions.foot_radius_m + self.decision_params.swing_margin_m
        )
        underside = np.where(maps.body_obstacle, np.inf, maps.ground_height + maps.clearance_m)
        remembered = self.overhangs.apply(maps.origin_xy, maps.resolution_m, underside)
        overhangs = HeightGrid(maps.origin_xy, maps.resolution_m, remembered)
        self.world = TerrainWorld(maps, regions, ground, self.path, overhangs)
        self._polygons = {}
        self._scan_xy = np.array(p_world_body[:2], dtype=np.float64)
        self.stats.scans += 1
        self.stats.regions_ms.append(regions.elapsed_ms)
        self.stats.perception_ms.append((time.perf_counter() - t0) * 1e3)

    def plan_path(self, p_world_body: NDArray[np.float64], yaw: float, t_s: float) -> None:
        """Replans the body path to the goal at path_rate_hz, and sooner when its sweep hits a body obstacle."""
        if self.world is None or self.goal is None:
            return
        due = t_s - self._t_path >= 1.0 / self.decision_params.path_rate_hz - 1e-9
        if not due and self.path is not None:
            path = self.path
            k = min(int(np.argmin(np.sum((path.xy - p_world_body[:2]) ** 2, axis=1))), len(path.s) - 1)
            rest = BodyPath(
                path.xy[k:], path.yaw[k:], path.s[k:] - path.s[k], path.method, path.valid, np.inf
            )
            rest_clear = sweep_clearance(self.world.maps, rest, self.path_params)
            if path_holds(rest_clear, path.min_clearance_m, self.decision_params.path_worse_m):
                return
        self._t_path = t_s
        self.path = plan_body_path(self.world.maps, p_world_body[:2], yaw, self.goal, self.path_params)
        self.world = dataclasses.replace(self.world, path=self.path)
        self.stats.body_paths += 1

    def decide(self, view: TerrainView) -> TerrainDecision | None:
        """Gives this tick's decision (None before the first maps)."""
        if self.world is None:
            return None
        d = decide(view, self.world, self.last, self.decision_params, self.facing, self.may_turn)
        self._watch_turn(view, d.facing)
        self.facing = d.facing
        xy, maps, p = view.p_world_body[:2], self.world.maps, self.params
        if view.goal is None:
            d = dataclasses.replace(d, command=stop_short(maps, xy, view.yaw, d.command, p.path, p.stop))
        elif p.barrier.margin_m is not None:
            kept = barrier_command(maps, xy, view.yaw, d.command, self.barrier_footprint, p.barrier)
            if kept is not d.command:
                self.stats.barrier_ticks += 1
                d = dataclasses.replace(d, command=kept)
        if d.gait != view.gait:
            self.stats.gait_switches += 1
        self.stats.slow_waits += int(d.slow_wait)
        if d.facing == "back":
            self.stats.backward_s += view.dt_s
        self.stats.min_height_m = min(self.stats.min_height_m, d.body_height_m)
        return d

    def _watch_turn(self, view: TerrainView, facing: Facing) -> None:
        """Gives up a turn round that has not come within turn_rad of its yaw in turn_timeout_s: forward from the
        next tick, and no other turn round in this walk."""
        p = self.decision_params
        if facing != "back" or self.world is None or self.world.path is None:
            self._turn_t0 = None
            return
        if self.facing != "back":
            self._turn_t0 = view.t_s
        if self._turn_t0 is None:
            return
        off = abs(math.remainder(view.yaw - travel_yaw(view, self.world.path, p) - math.pi, 2.0 * math.pi))
        if off <= p.turn_rad:
            self._turn_t0 = None  # turned
        elif view.t_s - self._turn_t0 > p.turn_timeout_s:
            self.may_turn = False
            self.stats.turns_given_up += 1

    def footholds(self, view: TerrainView, sel: Selection) -> Selection:
        """Gives the selection with its touchdowns on the regions (see choose_footholds)."""
        import time

        if self.world is None:
            return sel
        t0 = time.perf_counter()
        d = choose_footholds(
            view, sel.path, self.world, self.memory, self.qp, self.decision_params, self._polygons
        )
        self.memory = d.memory
        self.last = d
        self.stats.late_holds += d.late_holds
        if d.plan is not None or self.qp.last_bare_ms:
            self.stats.qp_solves += 1
        if d.plan is not None:
            self.stats.qp_ms.append(d.plan.solve_ms)
            self.stats.qp_bare_ms.append(d.plan.bare_solver_ms)
        self.stats.footholds_ms.append((time.perf_counter() - t0) * 1e3)
        return dataclasses.replace(
            sel, path=sel.path.with_touchdowns(d.p_world_touchdown, sel.path.kind + "+regions")
        )

    def overlays(self) -> dict[str, dict[str, Any]]:
        """The studio's terrain overlays: the maps' outlines, the body path, the step QP's footholds, the scan."""
        maps = self.maps
        if maps is None:
            return {}
        if self._overlay_maps is not maps:
            self._overlay_maps = maps
            self._overlay_outlines = map_overlays(maps, self._scan_xy)
        cloud = self.perception.last_cloud if self.perception is not None else None
        plan = None if self.last is None else self.last.plan
        return {**self._overlay_outlines, **plan_overlays(maps, self.path, plan, cloud)}
