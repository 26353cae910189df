"""Gaits (a table with units, MJPC style) and the clock that walks them and switches between them safely.

A gait is a cycle time, a duty factor and, per leg, the global phase at which that leg touches down. Leg ``l`` is
in stance while ``(phase - offset_l) mod 1 < duty``: stance first, then swing. The clock keeps one global phase
and, when a switch is requested, changes gait at a safe boundary: no foot in the air is ever declared on the
ground before its planned touchdown, and a foot on the ground is never lifted mid-way through the new gait's swing.
Legs that disagree with the new gait at the switch get a short per-leg hold (finish the swing, or stay in stance
until the new gait's next liftoff), so the new pattern is reached within about one cycle.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from planning.steps.state import F64, I64, N_LEGS, B


@dataclass(frozen=True)
class Gait:
    """One gait. cycle_s: s. duty: stance fraction of the cycle. offset: (4,) touchdown phase per leg FL, FR,
    RL, RR in cycles. swing_height_m: m. max_speed_mps: forward speed limit for this gait, m/s. max_vy_mps,
    max_yaw_rate_rps: its own sideways and turning limits where measured higher than the steering defaults."""

    name: str
    cycle_s: float
    duty: float
    offset: tuple[float, float, float, float]
    swing_height_m: float
    max_speed_mps: float
    max_vy_mps: float | None = None  # own sideways limit, m/s (None: the steering default, scaled)
    max_yaw_rate_rps: float | None = None  # own turning limit, rad/s (None: the steering default, scaled)

    def __post_init__(self) -> None:
        if not self.cycle_s > 0.0:
            raise ValueError(f"gait {self.name}: cycle_s must be > 0, got {self.cycle_s}")
        if not 0.0 < self.duty <= 1.0:
            raise ValueError(f"gait {self.name}: duty must be in (0, 1], got {self.duty}")
        if len(self.offset) != N_LEGS:
            raise ValueError(f"gait {self.name}: offset needs 4 phases (FL, FR, RL, RR)")

    @property
    def is_stand(self) -> bool:
        return self.duty >= 1.0

    @property
    def stance_s(self) -> float:
        return self.duty * self.cycle_s

    @property
    def swing_s(self) -> float:
        return (1.0 - self.duty) * self.cycle_s


# Gait table. Offsets are the global phase of each leg's touchdown; stance lasts duty * cycle from there.
# trot_fast: the trot above StepPlannerParams.fast_trot_above_mps forward or fast_trot_lateral_above_mps sideways
# (the planner switches to it and back by itself): a longer swing (duty 0.5) for the longer steps at speed; at duty
# 0.6 the swing feet could not reach their touchdowns in time above 1.2 m/s (measured: falls at 1.4 m/s; holds
# 1.8 m/s at duty 0.5). Its cycle is 0.4 s: at
# 0.5 s the diagonal's feet landed 0.26 m ahead of their hips at 2 m/s and the body rolled ±13-18° (±6° at 0.4 s),
# and a 1 m radius circle at 1.5 m/s fell (holds at 0.4 s).
# gallop: a transverse gallop, the hind pair then the front pair landing one after the other (left leads, the right
# 0.1 cycle later), two or three feet down (duty 0.5, always two, fell at 0.6 m/s); no flight phase. The bound and
# the gallop swing with the fast trot's swing limits (planning.walk.WalkParams.fast_swing_gaits): held 1.4 m/s
# (0.8 with the slow ones). Their 0.32 s cycle: at 0.40 s the bound commanded 2.5 m/s fell (46 % of its stance
# legs' ticks at a torque limit: long, heavily loaded stances) and the gallop at 2.5 fell from late feet; at 0.32 s
# both hold it (0.28 s: more late feet). The gallop's 0.30 s, with its swing feet's own 7.5 m/s limit
# (WalkParams.gait_swing_limits): 2.33-2.37 m/s asked 2.5 (with 7 m/s, 0.29 s: 2.32-2.38, 0.31: 2.17-2.35, 0.32:
# 2.15-2.34; five walks each: straight, ±0.2 and 0.4 rad/s, a turned start).
# Their caps (2.5 each) are what they tracked within 10 % from a stand, with the balance gains of
# WalkParams.pair_gait_* and the bound's footholds of ReferenceParams.thrust_lead_s.
#       name      cycle   duty    touchdown phase offset        swing height   max speed
#                 s       -       FL     FR     RL     RR       m              m/s
_GAIT_TABLE: tuple[tuple[str, float, float, tuple[float, float, float, float], float, float], ...] = (
    ("stand",     1.00,   1.00,   (0.00,  0.00,  0.00,  0.00),  0.00,          0.0),
    ("walk",      1.00,   0.75,   (0.25,  0.75,  0.00,  0.50),  0.08,          0.5),
    ("crawl",     1.60,   0.80,   (0.25,  0.75,  0.00,  0.50),  0.10,          0.3),
    ("climb",     0.60,   0.50,   (0.00,  0.50,  0.50,  0.00),  0.10,          0.5),
    ("stairs",    0.80,   0.50,   (0.00,  0.50,  0.50,  0.00),  0.10,          0.5),
    ("trot",      0.50,   0.60,   (0.00,  0.50,  0.50,  0.00),  0.10,          1.6),
    ("trot_fast", 0.40,   0.50,   (0.00,  0.50,  0.50,  0.00),  0.10,          2.0),
    ("pace",      0.36,   0.60,   (0.00,  0.50,  0.00,  0.50),  0.10,          1.0),
    ("bound",     0.32,   0.60,   (0.00,  0.00,  0.50,  0.50),  0.12,          2.5),
    ("gallop",    0.30,   0.60,   (0.50,  0.60,  0.00,  0.10),  0.12,          2.5),
)  # fmt: skip

# own sideways / turning limits (m/s, rad/s): the trots held 1.0 m/s sideways (ramped up to it) and 2.25 rad/s in
# the speed bench; from a stand, sideways above StepPlannerParams.fast_trot_lateral_above_mps walks trot_fast, which
# held 1.0 m/s (and 1.1, 1.2) in 14 of 14 starts: left and right, turned starts, ±0.1-0.2 m/s forward, 0.1-0.2 rad/s
# (the 0.5 s trot fell in 11 of 14 at 1.0, 3 of 14 at 0.9: docs/agility-notes.md, session 11)
_LATERAL: dict[str, tuple[float, float]] = {"trot": (1.0, 2.0), "trot_fast": (1.0, 2.0)}
GAITS: dict[str, Gait] = {row[0]: Gait(*row, *_LATERAL.get(row[0], (None, None))) for row in _GAIT_TABLE}
GAIT_NAMES: tuple[str, ...] = tuple(GAITS)


def get_gait(gait: Gait | str) -> Gait:
    """Returns the Gait for a name (or the Gait itself); raises ValueError naming the choices otherwise."""
    if isinstance(gait, Gait):
        return gait
    try:
        return GAITS[gait]
    except (KeyError, TypeError):
        raise ValueError(f"gait: unknown gait {gait!r} (choices: {', '.join(GAIT_NAMES)})") from None


@dataclass(frozen=True)
class Schedule:
    """Planned contact events from a time on, per touchdown, sorted by touchdown time.

    leg: (K,). t_touchdown: (K,) s. t_liftoff: (K,) s, liftoff that ends the stance begun at this touchdown (inf
    when beyond the window). t_liftoff_now: (4,) s, next liftoff of legs in stance now (inf beyond the window,
    nan for legs in swing now). contact_now: (4,) planned contact at the start time.
    """

    leg: I64
    t_touchdown: F64
    t_liftoff: F64
    t_liftoff_now: F64
    contact_now: B


_EPS_S = 1e-9  # s, nudge used to read the state just after an event


class GaitClock:
    """Advances the global gait phase and switches gait at a safe boundary (see the module docstring).

    The clock is the plan of contacts (not a contact sensor); it holds per-leg holds created at a switch.
    """

    def __init__(
        self,
        gait: Gait | str = "stand",
        t0: float = 0.0,
        max_start_progress: float = 0.2,
        min_stance_fraction: float = 0.5,
    ) -> None:
        """gait: initial gait. t0: s. max_start_progress: fraction of a swing already elapsed under which a foot
        in stance may lift off immediately when a new gait says it should be swinging. min_stance_fraction: a
        foot landing after a switch stays down at least this fraction of the new gait's stance time."""
        self.min_stance_fraction = float(min_stance_fraction)
        self.gait: Gait = get_gait(gait)
        self._t_ref = float(t0)  # s, time at which the global phase was 0
        self._holds: list[list[tuple[float, bool]]] = [[] for _ in range(N_LEGS)]
        self._pending: Gait | None = None
        self._t_last = float(t0)
        self.max_start_progress = float(max_start_progress)
        # s, a liftoff this close before a switch counts as at the switch (2 ticks)
        self.same_instant_s = 0.004
        self.t_switch: float = float(t0)  # s, time of the last switch

    # ---- queries ------------------------------------------------------------------------------------------------
    @property
    def pending(self) -> Gait | None:
        return self._pending

    def phase(self, t: float) -> float:
        """Returns the global phase of the current gait at time t (s), in [0, 1)."""
        return ((t - self._t_ref) / self.gait.cycle_s) % 1.0

    def _gait_contact(self, gait: Gait, t_ref: float, leg: int, t: float) -> bool:
        if gait.is_stand:
            return True
        # Read just after t: an event at t (up to rounding) has happened, as intervals are [start, end).
        ph = ((t + _EPS_S - t_ref) / gait.cycle_s - gait.offset[leg]) % 1.0
        return ph < gait.duty

    def _swing_progress(self, gait: Gait, t_ref: float, leg: int, t: float) -> float:
        ph = ((t + _EPS_S - t_ref) / gait.cycle_s - gait.offset[leg]) % 1.0
        return (ph - gait.duty) / (1.0 - gait.duty) if ph >= gait.duty else -1.0

    def _next_gait_event(self, gait: Gait, t_ref: float, leg: int, t: float, touchdown: bool) -> float:
        """Returns the first gait touchdown (or liftoff) time of ``leg`` strictly after t."""
        if gait.is_stand:
            return math.inf
        base = gait.offset[leg] + (0.0 if touchdown else gait.duty)
        m = math.floor((t - t_ref) / gait.cycle_s - base) + 1
        te = t_ref + (base + m) * gait.cycle_s
        while te <= t + _EPS_S:
            te += gait.cycle_s
        return te

    def leg_contact(self, leg: int, t: float) -> bool:
        """Returns the planned contact of one leg at time t (s), holds included."""
        for t_end, c in self._holds[leg]:
            if t + _EPS_S < t_end:
                return c
        return self._gait_contact(self.gait, self._t_ref, leg, t)

    def contact(self, t: float) -> B:
        """Returns the planned contact flags (4,) at time t (s)."""
        return np.array([self.leg_contact(i, t) for i in range(N_LEGS)], dtype=bool)

    def _leg_events(self, leg: int, t_from: float, t_to: float) -> list[tuple[float, bool]]:
        """Returns the contact changes (time, new contact) of one leg in (t_from, t_to], holds included."""
        out: list[tuple[float, bool]] = []
        c = self.leg_contact(leg, t_from)
        t = t_from
        # Window (t_from, t_to] with both ends nudged by _EPS_S, as in _next_gait_event, so that an event on a
        # boundary falls in exactly one of two adjacent windows despite rounding.
        holds = [h for h in self._holds[leg] if h[0] > t_from + _EPS_S]
        for t_end, _ in holds:
            if t_end > t_to + _EPS_S:
                return out
            c_new = self.leg_contact(leg, t_end + _EPS_S)
            if c_new != c:
                out.append((t_end, c_new))
                c = c_new
            t = t_end
        if self.gait.is_stand:
            return out
        while True:
            te = self._next_gait_event(self.gait, self._t_ref, leg, t, touchdown=not c)
            if te > t_to + _EPS_S:
                return out
            c = not c
            out.append((te, c))
            t = te

    def schedule(self, t: float, n_cycles: int = 2) -> Schedule:
        """Returns the planned touchdowns from time t (s): up to n_cycles touchdowns per leg, with liftoffs."""
        cyc = self.gait.cycle_s if not self.gait.is_stand else 1.0
        t_hold = max((h[-1][0] for h in self._holds if h), default=t)
        t_to = max(t, t_hold) + (n_cycles + 1.5) * cyc
        legs: list[int] = []
        t_td: list[float] = []
        t_lo: list[float] = []
        t_lo_now = np.full(N_LEGS, np.nan)
        contact_now = self.contact(t)
        for leg in range(N_LEGS):
            events = self._leg_events(leg, t, t_to)
            if contact_now[leg]:
                t_lo_now[leg] = next((te for te, c in events if not c), math.inf)
            n = 0
            for i, (te, c) in enumerate(events):
                if c and n < n_cycles:
                    legs.append(leg)
                    t_td.append(te)
                    t_lo.append(next((te2 for te2, c2 in events[i + 1 :] if not c2), math.inf))
                    n += 1
        order = np.argsort(np.asarray(t_td, dtype=np.float64), kind="stable")
        return Schedule(
            leg=np.asarray(legs, dtype=np.int64)[order],
            t_touchdown=np.asarray(t_td, dtype=np.float64)[order],
            t_liftoff=np.asarray(t_lo, dtype=np.float64)[order],
            t_liftoff_now=t_lo_now,
            contact_now=contact_now,
        )

    # ---- switching ----------------------------------------------------------------------------------------------
    def request(self, gait: Gait | str) -> None:
        """Queues a switch to ``gait``; it takes effect at the next safe boundary (see advance)."""
        g = get_gait(gait)
        self._pending = None if (g == self.gait and self._pending is None) else g

    def advance(self, t: float) -> bool:
        """Moves the clock to time t (s); applies a pending switch at a safe boundary. Returns True on a switch.

        Boundaries: at once when standing or when the new gait is a stand (feet in the air finish their swing);
        otherwise at the first touchdown since the last call, which anchors the new gait's phase.
        """
        t_prev, self._t_last = self._t_last, float(t)
        for h in self._holds:
            while h and h[0][0] <= t - 1.0:  # drop holds long past (keeps lists short)
                h.pop(0)
        g = self._pending
        if g is None:
            return False
        if g == self.gait:
            self._pending = None
            return False
        if self.gait.is_stand or g.is_stand:
            self._switch(g, t, anchor=None)
            return True
        anchors = [(leg, te) for leg in range(N_LEGS) for te, c in self._leg_events(leg, t_prev, t) if c]
        if not anchors:
            return False
        # Of the legs that just landed, anchor the new gait on the one that needs the fewest per-leg holds.
        best = min(anchors, key=lambda a: (sum(map(len, self._holds_for(g, t, a))), -a[1], a[0]))
        self._switch(g, t, anchor=best)
        return True

    def hold(self, dt: float) -> None:
        """Holds the gait's phase for dt (s): every planned event from now on, the gait's and the per-leg holds',
        moves dt later, as if the clock had stood still. The walk controller holds it while a liftoff waits for
        static balance (planning.steps.support.SupportShiftParams.hold_clock), so that the held swing keeps its
        duration and the legs after it keep theirs."""
        if dt <= 0.0 or self.gait.is_stand:
            return
        self._t_ref += dt
        for h in self._holds:
            for i, (t_end, c) in enumerate(h):
                h[i] = (t_end + dt, c)

    def _t_ref_for(self, g: Gait, t: float, anchor: tuple[int, float] | None) -> float:
        if g.is_stand:
            t_ref1 = t
        elif anchor is None:
            # From a stand: start where some leg lifts off now, choosing the phase with fewest legs mid-swing.
            best: tuple[int, float] | None = None
            for leg in range(N_LEGS):
                ph = g.offset[leg] + g.duty
                n_mid = sum(
                    1
                    for other in range(N_LEGS)
                    if self._swing_progress(g, -ph * g.cycle_s, other, 0.0 + _EPS_S) > self.max_start_progress
                )
                if best is None or n_mid < best[0]:
                    best = (n_mid, ph)
            assert best is not None
            t_ref1 = t - best[1] * g.cycle_s
        else:
            leg_a, t_a = anchor
            t_ref1 = t_a - g.offset[leg_a] * g.cycle_s
        return t_ref1

    def _last_event(self, leg: int, t_to: float, touchdown: bool) -> float:
        """Returns the leg's last touchdown (or liftoff) up to t_to (searching back up to two old-gait cycles)."""
        span = 2.0 * (self.gait.cycle_s if not self.gait.is_stand else 1.0)
        events = [te for te, c in self._leg_events(leg, t_to - span, t_to) if c == touchdown]
        return events[-1] if events else -math.inf

    def _last_touchdown(self, leg: int, t: float) -> float:
        """Returns when the leg, in stance at t, last landed."""
        return self._last_event(leg, t, touchdown=True)

    def _last_liftoff(self, leg: int, t: float) -> float:
        """Returns when the leg, in swing at t, last lifted off (a liftoff at t included)."""
        return self._last_event(leg, t + _EPS_S, touchdown=False)

    def _holds_for(
        self, g: Gait, t: float, anchor: tuple[int, float] | None
    ) -> list[list[tuple[float, bool]]]:
        t_ref1 = self._t_ref_for(g, t, anchor)
        min_stance = self.min_stance_fraction * g.stance_s
        pairs = g.duty < 0.75 - 1e-9  # the new gait has two legs in the air at once (a trot, pace, bound)
        holds: list[list[tuple[float, bool]]] = [[] for _ in range(N_LEGS)]
        for leg in range(N_LEGS):
            c0 = self.leg_contact(leg, t + _EPS_S)
            c1 = self._gait_contact(g, t_ref1, leg, t + _EPS_S)
            if c0 and c1 and not g.is_stand:
                t_lo1 = self._next_gait_event(g, t_ref1, leg, t, touchdown=False)
                if t_lo1 - self._last_touchdown(leg, t) < min_stance:
                    holds[leg].append((self._next_gait_event(g, t_ref1, leg, t_lo1, touchdown=False), True))
            elif c0 and not c1:
                late = self._swing_progress(g, t_ref1, leg, t + _EPS_S) > self.max_start_progress
                if late or t - self._last_touchdown(leg, t) < min_stance:
                    holds[leg].append((self._next_gait_event(g, t_ref1, leg, t, touchdown=False), True))
            elif not c0 and c1 and pairs and t - self._last_liftoff(leg, t) <= self.same_instant_s:
                # An old-gait swing that begins at the switch itself (at a walk's touchdown the diagonal leg lifts
                # at the same instant) is not a foot in flight: when the new gait swings legs in pairs, the leg
                # stays down with it rather than swing on while the new gait lifts a pair (three feet up at once).
                continue
            elif not c0:
                # Finish the swing in flight at its planned time, then follow the new gait (holding stance
                # through a new-gait swing that would already be under way).
                t_td0 = next((te for te, c in self._leg_events(leg, t, t + 10.0 * self.gait.cycle_s) if c), t)
                holds[leg].append((t_td0, False))
                t_lo1 = self._next_gait_event(g, t_ref1, leg, t_td0, touchdown=False)
                short = t_lo1 - t_td0 < min_stance
                if short or not self._gait_contact(g, t_ref1, leg, t_td0 + _EPS_S):
                    # Stay down through a new-gait swing already under way, or through a stance too short.
                    if short and self._gait_contact(g, t_ref1, leg, t_td0 + _EPS_S):
                        t_lo1 = self._next_gait_event(g, t_ref1, leg, t_lo1, touchdown=False)
                    holds[leg].append((t_lo1, True))
        return holds

    def _switch(self, g: Gait, t: float, anchor: tuple[int, float] | None) -> None:
        t_ref1 = self._t_ref_for(g, t, anchor)
        holds = self._holds_for(g, t, anchor)
        self.gait = g
        self._t_ref = t_ref1
        self._holds = holds
        self._pending = None
        self.t_switch = float(t)
