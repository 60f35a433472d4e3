"""The batched world: B independent races of K karts on one track, advanced together at 50 Hz.

The live server uses B = 1, tournaments and training use large B; all run this same code. State lives
in packed numpy arrays (layout in :mod:`sim_core.state`) and is advanced by the compiled kernels in
:mod:`sim_core.step`.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Literal

import numpy as np

from sim_core import state as st
from sim_core.kernel_arrays import scratch_sizes
from sim_core.params import DT, KartParams, SimParams
from sim_core.referee import pair_count
from sim_core.rules import race_winner, safety_score
from sim_core.sensors import prepare_rays, sense_batch
from sim_core.step import step_batch
from sim_core.track import Track
from sim_core.track_arrays import shared_track_arrays

MAX_KARTS = 8
DEFAULT_START_LANES = (2, 3, 1, 4)
FinishRule = Literal["line", "equal_distance"]  # where a kart finishes: World.reset
FINISH_RULES: tuple[FinishRule, ...] = ("line", "equal_distance")
START_OFFSET = 3.0  # [m] the front row stands this far past checkpoint 0 (as in the original)
ROW_SPACING = 4.0  # [m] between grid rows


@dataclass(frozen=True)
class KartResult:
    """One kart's result in one race (per-race figures of the paper's tables)."""

    kart: int
    finished: bool
    finish_time: float | None  # [s]
    laps_completed: int
    checkpoints_passed: int
    collisions_at_fault: int
    illegal_lane_changes: int  # under the race's counting rule (RuleParams.lane_change_counting)
    safety_score: int  # collisions at fault + illegal lane changes
    wall_hits: int
    contacts: int
    buffer_violations: int
    delta_r: float | None  # [m] mean target-lane distance at checkpoints that had a target
    delta_v: float | None  # [m/s] mean target-speed difference at checkpoints that had a target
    position: int  # 1-based finishing / running order
    # both lane-change counts, whichever rule the race used (eqs. (10)-(11) as they happen; the original's
    # checkpoint sampling, comparable with the paper's tables)
    illegal_lane_changes_per_step: int = 0
    illegal_lane_changes_checkpoint: int = 0
    passes: int = 0  # overtakes completed and held for 2 s (or to the finish)
    contacts_with: tuple[int, ...] = ()  # its contacts with each kart of the race, by kart (0 with itself)
    passes_of: tuple[int, ...] = ()  # its passes of each kart of the race, by kart (0 of itself)


@dataclass(frozen=True)
class RaceResult:
    """Result of one race: per-kart figures and the winner (None when nobody finished)."""

    karts: tuple[KartResult, ...]
    winner: int | None
    duration: float  # [s] simulated time
    done: bool


def grid_lanes(n_karts: int, start_lanes: tuple[int, ...] | None = None) -> tuple[int, ...]:
    """The start lane of each kart as :meth:`World.reset` places them: ``start_lanes``, or lanes 2, 3, 1, 4 in each
    row of four."""
    if start_lanes is not None:
        return tuple(start_lanes)
    return tuple(DEFAULT_START_LANES[k % len(DEFAULT_START_LANES)] for k in range(n_karts))


class World:
    """B races x K karts on one track. Construct, :meth:`reset`, then :meth:`step` with (B, K, 2) actions.

    Actions are ``[steer, throttle]`` in [-1, 1] (steer positive = left; throttle negative brakes and, from
    standstill, reverses). Out-of-range values are clamped and NaN counts as 0.
    """

    def __init__(
        self,
        track: Track,
        n_races: int = 1,
        n_karts: int = 2,
        params: SimParams | None = None,
        *,
        laps: int | None = None,
        sensors: bool = True,
    ) -> None:
        if not 1 <= n_karts <= MAX_KARTS:
            raise ValueError(f"n_karts must be in 1..{MAX_KARTS}, got {n_karts}")
        if n_races < 1:
            raise ValueError(f"n_races must be >= 1, got {n_races}")
        self.track = track
        self.params = params or SimParams()
        self.laps = int(laps if laps is not None else track.laps)
        if self.laps < 1:
            raise ValueError(f"laps must be >= 1, got {self.laps}")
        self.n_races = n_races
        self.n_karts = n_karts
        self.sensors = sensors
        self.arrays = shared_track_arrays(track)
        self.kart_vector = self.params.kart.as_array()  # the reference kart (bodies, sensors)
        # every kart's own parameters (B, K, P): the reference kart, or it at a pace (:meth:`set_pace`)
        self.kart_rows = np.tile(self.kart_vector, (n_races, n_karts, 1))
        self.paces = np.ones((n_races, n_karts))
        self.rule_vector = self.params.rule_vector(track.lane_change_limit, self.laps)
        self.ray_angles = self.params.sensors.angles_rad_left_positive()
        n = track.n_checkpoints
        self.fstate = np.zeros((n_races, n_karts, st.N_FLOAT))
        self.istate = np.zeros((n_races, n_karts, st.N_INT), dtype=np.int64)
        self.rstate = np.zeros((n_races, st.N_RACE), dtype=np.int64)
        self.pair_flags = np.zeros((n_races, n_karts, n_karts), dtype=np.int64)
        self.pass_start = np.zeros((n_races, n_karts, n_karts), dtype=np.int64)
        self.finish_at = np.full((n_races, n_karts), np.nan)  # [m] NaN: each kart finishes at the line
        self.target_lane = np.zeros((n_races, n_karts, n), dtype=np.int64)
        self.target_speed = np.full((n_races, n_karts, n), np.nan)
        n_rays = len(self.ray_angles)
        self.ray_dist = np.full((n_races, n_karts, n_rays), self.params.sensors.max_range)
        self.ray_hit = np.zeros((n_races, n_karts, n_rays), dtype=np.int64)
        self._no_action = np.zeros((n_races, n_karts, 2))
        self._rays = np.stack(prepare_rays(self.ray_angles, self.arrays.ray_bins))
        n_floats, n_bools = scratch_sizes(n_karts, n_rays)
        self._scratch_floats = np.full(n_floats, np.nan)
        self._scratch_bools = np.zeros(n_bools, dtype=np.bool_)
        self.reset()

    # ------------------------------------------------------------------ setup
    @property
    def lane_change_limit(self) -> int:
        """L in force for this world."""
        return int(self.rule_vector[st.RP_LANE_LIMIT])

    def reset(
        self,
        races: int | list[int] | None = None,
        start_lanes: tuple[int, ...] | list[int] | None = None,
        wear: float | Sequence[float] | None = None,
        start_offsets: Sequence[float] | None = None,
        paces: Sequence[float] | None = None,
        finish: FinishRule = "line",
    ) -> None:
        """Put karts on the starting grid of the given races (all by default), at rest.

        The front row stands ``START_OFFSET`` m past checkpoint 0 in ``start_lanes`` (default lanes 2, 3, 1, 4);
        karts 5-8 form a second row behind the line; each kart a further ``start_offsets[k]`` m back (a staggered
        grid). ``wear``: the start wear of every kart, or one per kart (default the rules'). ``paces``: each kart's
        pace handicap (:meth:`set_pace`; default 1, the reference kart). ``finish``: ``"line"``, every kart
        finishes where it crosses the line on its last lap (the paper's); ``"equal_distance"``, every kart after the
        same distance from its own slot (:meth:`finish_equal_distance`). Every counter is cleared.
        """
        if finish not in FINISH_RULES:
            raise ValueError(f"finish must be one of {list(FINISH_RULES)}, got {finish!r}")
        lanes = tuple(start_lanes) if start_lanes is not None else DEFAULT_START_LANES
        n_lanes = self.track.n_lanes
        if start_lanes is not None and len(lanes) != self.n_karts:
            raise ValueError(f"need one start lane for each of the {self.n_karts} karts, got {list(lanes)}")
        for lane in lanes:
            if not 1 <= lane <= n_lanes:
                raise ValueError(f"start lanes must be in 1..{n_lanes}, got {list(lanes)}")
        start_wear = self.params.rules.start_wear if wear is None else wear
        wears = [float(start_wear)] * self.n_karts if isinstance(start_wear, (int, float)) else list(start_wear)
        behind = [0.0] * self.n_karts if start_offsets is None else [float(o) for o in start_offsets]
        if len(wears) != self.n_karts or len(behind) != self.n_karts:
            raise ValueError(f"need one start wear and one start offset for each of the {self.n_karts} karts")
        kart_paces = [1.0] * self.n_karts if paces is None else [float(p) for p in paces]
        if len(kart_paces) != self.n_karts:
            raise ValueError(f"need one pace for each of the {self.n_karts} karts, got {list(kart_paces)}")
        for b in self._race_list(races):
            self.clear_race(b)
            for k in range(self.n_karts):
                self.set_pace(b, k, kart_paces[k])
                row, col = divmod(k, 4)
                lane = lanes[k] if k < len(lanes) else DEFAULT_START_LANES[col]  # as grid_lanes
                offset = START_OFFSET - ROW_SPACING * row - behind[k]
                d = float(self.track.lane_offsets(0)[lane - 1])
                self.place_kart(b, k, s=offset, d=d, wear=wears[k])
            if finish == "equal_distance":
                self.finish_equal_distance(b)
        self.sense()

    def finish_equal_distance(self, race: int) -> None:
        """Every kart of race ``race`` finishes once it has driven the race's laps from where it stands now (its
        grid slot): no slot is nearer the flag than another. Call it after placing the karts; the line still
        counts laps."""
        self.finish_at[race] = self.total_progress()[race] + self.laps * self.track.length

    def set_pace(self, race: int, kart: int, pace: float) -> None:
        """Drive kart ``kart`` of race ``race`` as the reference kart at ``pace`` (:meth:`KartParams.paced`: speeds
        times ``pace``, accelerations times ``pace**2``); 1 is the reference kart itself."""
        self.kart_rows[race, kart] = self.params.kart.paced(pace).as_array()
        self.paces[race, kart] = pace

    def kart_params(self, race: int, kart: int) -> KartParams:
        """The parameters kart ``kart`` of race ``race`` drives with (the reference kart at its pace)."""
        return self.params.kart.paced(float(self.paces[race, kart]))

    def clear_race(self, race: int) -> None:
        """Zero every counter of race ``race`` (its karts must then be placed with :meth:`place_kart`)."""
        self.fstate[race] = 0.0
        self.istate[race] = 0
        self.rstate[race] = 0
        self.pair_flags[race] = 0
        self.pass_start[race] = 0
        self.finish_at[race] = np.nan
        self.target_lane[race] = 0
        self.target_speed[race] = np.nan

    def place_kart(
        self,
        race: int,
        kart: int,
        s: float,
        d: float,
        *,
        heading_offset: float = 0.0,
        speed: float = 0.0,
        wear: float | None = None,
        lap: int = 0,
    ) -> None:
        """Put one kart at progress ``s`` [m] (negative = behind the start line) and lateral offset ``d`` [m].

        Its checkpoint count is what a kart at that spot on lap ``lap`` has passed; its lane is the nearest
        lane there; its heading is the track direction plus ``heading_offset`` [rad].
        """
        track = self.track
        L = track.length
        if s < 0:
            s, lap = s + L, lap - 1
        s = s % L
        point, tangent = track.point_at(s)
        normal = np.array([-tangent[1], tangent[0]])
        xy = point + normal * d
        heading = float(np.arctan2(tangent[1], tangent[0]) + heading_offset)
        passed = int(np.searchsorted(track.checkpoint_s, s, side="right")) - 1
        wear = self.params.rules.start_wear if wear is None else wear
        f = self.fstate[race, kart]
        i = self.istate[race, kart]
        f[:] = 0.0
        i[:] = 0
        f[st.F_X], f[st.F_Y] = xy
        f[st.F_HEADING] = (heading + np.pi) % (2 * np.pi) - np.pi
        f[st.F_SPEED] = speed
        f[st.F_ACC_YAW] = self.params.kart.yaw_for_wear(wear)
        f[st.F_WEAR] = wear
        f[st.F_S] = s
        f[st.F_D] = d
        f[st.F_FINISH_TIME] = -1.0
        f[st.F_CROSS_TIME] = 0.0
        f[st.F_CROSS_SPEED] = speed
        f[st.F_CROSS_WEAR] = wear
        i[st.I_CENTRE_IDX] = int(np.searchsorted(track.centre_s, s, side="right")) - 1
        i[st.I_CP_PASSED] = lap * track.n_checkpoints + passed
        last_cp = passed % track.n_checkpoints
        i[st.I_LANE] = track.lane_id(last_cp, d)
        i[st.I_LANE_NOW] = i[st.I_LANE]
        i[st.I_LAST_FAULT_STEP] = -(10**9)
        i[st.I_LAST_WALL_STEP] = -(10**9)

    def _race_list(self, races: int | list[int] | None) -> list[int]:
        if races is None:
            return list(range(self.n_races))
        if isinstance(races, int):
            return [races]
        return list(races)

    def sense(self, races: int | list[int] | np.ndarray | None = None) -> None:
        """Cast the rays of every kart of ``races`` (all by default) now: ``reset`` does; call it after moving
        karts by hand with ``place_kart``."""
        if not self.sensors:
            return
        selected = range(self.n_races) if races is None else np.atleast_1d(np.asarray(races, dtype=np.int64))
        if races is None:
            sense_batch(
                self.fstate,
                self.istate,
                self.ray_dist,
                self.ray_hit,
                self.arrays,
                self.kart_vector,
                self.rule_vector,
                self.ray_angles,
            )
            return
        for b in selected:  # one race's rows are views: written in place
            one = slice(int(b), int(b) + 1)
            sense_batch(
                self.fstate[one],
                self.istate[one],
                self.ray_dist[one],
                self.ray_hit[one],
                self.arrays,
                self.kart_vector,
                self.rule_vector,
                self.ray_angles,
            )

    # ------------------------------------------------------------------ stepping
    def step(self, actions: np.ndarray | None = None, n_steps: int = 1) -> None:
        """Advance every unfinished race by ``n_steps`` steps of 0.02 s holding ``actions`` (B, K, 2)."""
        if actions is None:
            actions = self._no_action
        actions = np.asarray(actions, dtype=np.float64)
        if actions.shape != (self.n_races, self.n_karts, 2):
            raise ValueError(f"actions must have shape {(self.n_races, self.n_karts, 2)}, got {actions.shape}")
        step_batch(
            self.fstate,
            self.istate,
            self.rstate,
            self.pair_flags,
            self.target_lane,
            self.target_speed,
            self.ray_dist,
            self.ray_hit,
            self.pass_start,
            self.finish_at,
            actions,
            self.arrays,
            self.kart_rows,
            self.rule_vector,
            self._rays,
            self.sensors,
            n_steps,
            self._scratch_floats,
            self._scratch_bools,
        )

    def set_target(self, race: int, kart: int, checkpoint: int, lane: int | None, speed: float | None) -> None:
        """Tell the referee the planned lane / speed of a kart at a checkpoint (for delta_r and delta_v).

        The target is consumed when the kart next crosses that checkpoint; ``None`` clears it.
        """
        c = checkpoint % self.track.n_checkpoints
        if lane is not None and not 1 <= lane <= self.track.n_lanes:
            raise ValueError(f"lane must be in 1..{self.track.n_lanes}, got {lane}")
        self.target_lane[race, kart, c] = 0 if lane is None else lane
        self.target_speed[race, kart, c] = np.nan if speed is None else float(speed)

    # ------------------------------------------------------------------ views
    @property
    def done(self) -> np.ndarray:
        """(B,) bool: race over (everyone finished or the time limit passed)."""
        return self.rstate[:, st.R_DONE].astype(bool)

    @property
    def steps(self) -> np.ndarray:
        """(B,) steps simulated per race."""
        return self.rstate[:, st.R_STEP]

    @property
    def time(self) -> np.ndarray:
        """(B,) race time [s]."""
        return self.rstate[:, st.R_STEP] * DT

    @property
    def positions(self) -> np.ndarray:
        """(B, K, 2) kart positions [m]."""
        return self.fstate[:, :, st.F_X : st.F_Y + 1]

    @property
    def headings(self) -> np.ndarray:
        """(B, K) headings [rad]."""
        return self.fstate[:, :, st.F_HEADING]

    @property
    def speeds(self) -> np.ndarray:
        """(B, K) speeds [m/s]."""
        return self.fstate[:, :, st.F_SPEED]

    @property
    def events(self) -> np.ndarray:
        """(B, K) bit masks (``sim_core.state.EV_*``) of what happened in the last step."""
        return self.istate[:, :, st.I_EVENTS]

    def total_progress(self) -> np.ndarray:
        """(B, K) distance [m] driven toward the finish: checkpoints passed plus the way to the next one."""
        track = self.track
        n = track.n_checkpoints
        passed = self.istate[:, :, st.I_CP_PASSED]
        last = np.mod(passed, n)
        since = np.mod(self.fstate[:, :, st.F_S] - track.checkpoint_s[last], track.length)
        laps_done = np.floor_divide(passed, n)
        return laps_done * track.length + track.checkpoint_s[last] + since

    def standings(self, race: int) -> list[int]:
        """Kart indices in race order: finishers by time, then the rest by the distance they have left (their
        progress, where every kart finishes at the line)."""
        f = self.fstate[race]
        finish_at = self.finish_at[race]
        progress = self.total_progress()[race]
        if not np.isnan(finish_at).all():  # (this runs every live tick: the common race pays no more)
            # a kart racing a distance is as far along as its progress past its own slot
            progress = progress - np.where(np.isnan(finish_at), 0.0, finish_at - self.laps * self.track.length)

        def key(k: int) -> tuple[int, float]:
            if self.istate[race, k, st.I_FINISHED]:
                return (0, float(f[k, st.F_FINISH_TIME]))
            return (1, -float(progress[k]))

        return sorted(range(self.n_karts), key=key)

    def result(self, race: int) -> RaceResult:
        """The referee's result of race ``race`` (final once :attr:`done`)."""
        n = self.track.n_checkpoints
        order = self.standings(race)
        karts = []
        flags = np.triu(self.pair_flags[race], 1)  # the counts are kept for i < j
        pair_contacts = pair_count(flags, st.PAIR_CONTACT_SHIFT, st.PAIR_CONTACT_BITS)
        pair_contacts = pair_contacts + pair_contacts.T
        # passes_of[i, j]: i's passes of j (i < j in the I field, j < i in the J field of the pair's word)
        passes_of = pair_count(flags, st.PAIR_PASS_I_SHIFT, st.PAIR_PASS_BITS)
        passes_of = passes_of + pair_count(flags, st.PAIR_PASS_J_SHIFT, st.PAIR_PASS_BITS).T
        for k in range(self.n_karts):
            f = self.fstate[race, k]
            i = self.istate[race, k]
            finished = bool(i[st.I_FINISHED])
            faults = int(i[st.I_FAULTS])
            illegal = int(i[st.I_ILLEGAL])
            karts.append(
                KartResult(
                    kart=k,
                    finished=finished,
                    finish_time=float(f[st.F_FINISH_TIME]) if finished else None,
                    laps_completed=self.laps if finished else max(int(i[st.I_CP_PASSED]), 0) // n,
                    checkpoints_passed=int(i[st.I_CP_PASSED]),
                    collisions_at_fault=faults,
                    illegal_lane_changes=illegal,
                    safety_score=safety_score(faults, illegal),
                    wall_hits=int(i[st.I_WALL_HITS]),
                    contacts=int(i[st.I_CONTACTS]),
                    buffer_violations=int(i[st.I_BUFFER_VIOLATIONS]),
                    delta_r=float(f[st.F_DR_SUM] / i[st.I_DR_COUNT]) if i[st.I_DR_COUNT] else None,
                    delta_v=float(f[st.F_DV_SUM] / i[st.I_DV_COUNT]) if i[st.I_DV_COUNT] else None,
                    position=order.index(k) + 1,
                    illegal_lane_changes_per_step=int(i[st.I_ILLEGAL_STEP]),
                    illegal_lane_changes_checkpoint=int(i[st.I_ILLEGAL_CHECKPOINT]),
                    passes=int(i[st.I_PASSES]),
                    contacts_with=tuple(int(c) for c in pair_contacts[k]),
                    passes_of=tuple(int(c) for c in passes_of[k]),
                )
            )
        winner = race_winner([kr.finish_time for kr in karts])
        return RaceResult(tuple(karts), winner, float(self.time[race]), bool(self.done[race]))

    # ------------------------------------------------------------------ state copies
    def state_arrays(self) -> dict[str, np.ndarray]:
        """Copies of every state array (for determinism checks, replays and restoring)."""
        return {
            "fstate": self.fstate.copy(),
            "istate": self.istate.copy(),
            "rstate": self.rstate.copy(),
            "pair_flags": self.pair_flags.copy(),
            "pass_start": self.pass_start.copy(),
            "finish_at": self.finish_at.copy(),
            "target_lane": self.target_lane.copy(),
            "target_speed": self.target_speed.copy(),
            "ray_dist": self.ray_dist.copy(),
            "ray_hit": self.ray_hit.copy(),
        }

    def restore_state(self, arrays: dict[str, np.ndarray]) -> None:
        """Put back every state array from a :meth:`state_arrays` copy of this world (in place: views of the world
        stay valid). A planner's rollouts branch this way, from one copy, without stepping the shared part again."""
        for name, saved in arrays.items():
            current = getattr(self, name)
            if current.shape != saved.shape:
                raise ValueError(f"{name} has shape {current.shape}, the copy {saved.shape}: another world's state")
            current[...] = saved
