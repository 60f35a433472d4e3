"""What happened when in a recorded race: the race re-simulated from its replay's inputs, step by step.

A replay (:class:`controllers.replay.Replay`) keeps every kart's pose and inputs per step, but not the
referee's counters. The simulation is deterministic, so stepping a fresh world of the same track, laps, kart
preset and grid with the recorded inputs gives the race again, and with it every checkpoint crossing (lap and
sector times), the running order, tyre wear, and each incident as it happened: collisions at fault, illegal
lane changes, wall hits and passes. :attr:`RaceTimeline.pose_error` says how closely the re-simulated poses
follow the recorded ones (0 when the simulation is the one that ran the race).

Plans only feed the referee's Δr / Δv sums and never the motion, so they are not replayed here.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from sim_core import state as st
from sim_core.conditions import RaceConditions
from sim_core.params import DT, SimParams
from sim_core.track import Track
from sim_core.world import World

COLLISION_AT_FAULT = "collision_at_fault"
ILLEGAL_LANE_CHANGE = "illegal_lane_change"
WALL_HIT = "wall_hit"
PASS = "pass"
INCIDENT_KINDS = (COLLISION_AT_FAULT, ILLEGAL_LANE_CHANGE, WALL_HIT, PASS)
_EVENT_KINDS = (
    (st.EV_FAULT_COLLISION, COLLISION_AT_FAULT),
    (st.EV_ILLEGAL_LANE_CHANGE, ILLEGAL_LANE_CHANGE),
    (st.EV_WALL_HIT, WALL_HIT),
)
TIME_LIMIT_MARGIN = 1.0  # [s] the re-simulation's time limit lies this far past the replay's end


@dataclass(frozen=True)
class Crossing:
    """A kart crossing a checkpoint (``checkpoint`` counts from the start: lap ``checkpoint // N``)."""

    kart: int
    checkpoint: int  # absolute: 1 is the first checkpoint after the start line, N the end of lap 1
    time: float  # [s] race time, interpolated within the step
    speed: float  # [m/s]
    wear: float  # [-] tyre wear


@dataclass(frozen=True)
class Incident:
    """Something the referee judged: a collision at fault, an illegal lane change, a wall hit or a pass.

    ``other`` is the kart passed (``pass``) or touched (``collision_at_fault``, the nearest kart in contact),
    else ``None``. A pass is dated when the passer got ahead; the referee counts it once held for 2 s.
    """

    time: float  # [s] race time
    kart: int
    kind: str  # one of INCIDENT_KINDS
    other: int | None = None


@dataclass(frozen=True)
class RaceTimeline:
    """A race step by step (row ``i`` is the state after ``i`` steps; row 0 is the grid), ``K`` karts.

    Arrays of shape ``(steps + 1, K)``: ``x``, ``y`` [m], ``heading`` [rad], ``speed`` [m/s] (the recorded
    poses), ``distance`` [m] along the centre line within the lap, ``progress`` [m] toward the finish,
    ``wear`` [-], ``checkpoints_passed``, ``lane`` (1-based, at the last crossing), ``position`` (1-based running
    order), the cumulative ``collisions_at_fault``, ``illegal_lane_changes``, ``wall_hits`` and ``passes``, and
    ``finished``.
    """

    dt: float  # [s] per step
    n_checkpoints: int
    track_length: float  # [m]
    x: np.ndarray
    y: np.ndarray
    heading: np.ndarray
    speed: np.ndarray
    distance: np.ndarray
    progress: np.ndarray
    wear: np.ndarray
    checkpoints_passed: np.ndarray
    lane: np.ndarray
    position: np.ndarray
    collisions_at_fault: np.ndarray
    illegal_lane_changes: np.ndarray
    wall_hits: np.ndarray
    passes: np.ndarray
    finished: np.ndarray
    finish_time: tuple[float | None, ...]  # [s] per kart
    crossings: tuple[Crossing, ...]  # in time order
    incidents: tuple[Incident, ...]  # in time order
    pose_error: float  # [m] largest distance between a re-simulated and a recorded position

    @property
    def steps(self) -> int:
        """Steps recorded (the race lasted ``steps * dt`` seconds)."""
        return int(self.x.shape[0]) - 1

    @property
    def n_karts(self) -> int:
        """Karts in the race."""
        return int(self.x.shape[1])


def resimulate(
    poses: np.ndarray,
    track: Track,
    laps: int,
    params: SimParams,
    start_lanes: tuple[int, ...] | None = None,
    conditions: RaceConditions | None = None,
    paces: tuple[float, ...] | None = None,
) -> RaceTimeline:
    """The race whose replay recorded ``poses`` (steps, K, 6: x, y, heading, speed, steer, throttle per step),
    run again with its recorded inputs on ``track`` over ``laps`` laps with ``params`` (the race's kart preset)
    from the grid of ``start_lanes``, with the start wear, grid offsets and finish rule of the race's
    ``conditions`` as drawn (None: the paper's) and each kart at its pace ``paces`` (None: the conditions' draw, or
    the reference kart)."""
    poses = np.asarray(poses, dtype=np.float64)
    if poses.ndim != 3 or poses.shape[2] != 6 or poses.shape[1] < 1:
        raise ValueError(f"poses must have shape (steps, karts, 6), got {poses.shape}")
    n_steps, n_karts = poses.shape[0], poses.shape[1]
    # a tournament may have raced under a longer time limit than the rules' default: never stop before the end
    rules = replace(params.rules, time_limit=max(params.rules.time_limit, n_steps * DT + TIME_LIMIT_MARGIN))
    world = World(track, 1, n_karts, replace(params, rules=rules), laps=laps, sensors=False)
    if conditions is None:
        world.reset(start_lanes=start_lanes, paces=paces)
    else:
        world.reset(
            start_lanes=start_lanes,
            wear=conditions.start_wear,
            start_offsets=conditions.start_offsets,
            paces=paces if paces is not None else conditions.paces,
            finish=conditions.finish,
        )

    shape = (n_steps + 1, n_karts)
    floats = {name: np.zeros(shape) for name in ("distance", "progress", "wear")}
    ints = {
        name: np.zeros(shape, dtype=np.int64)
        for name in ("checkpoints_passed", "lane", "collisions_at_fault", "illegal_lane_changes", "wall_hits")
    }
    passes = np.zeros(shape, dtype=np.int64)
    finished = np.zeros(shape, dtype=bool)
    sim_xy = np.zeros((n_steps + 1, n_karts, 2))
    crossings: list[Crossing] = []
    incidents: list[Incident] = []
    columns = (
        ("checkpoints_passed", st.I_CP_PASSED),
        ("lane", st.I_LANE),
        ("collisions_at_fault", st.I_FAULTS),
        ("illegal_lane_changes", st.I_ILLEGAL),
        ("wall_hits", st.I_WALL_HITS),
    )
    actions = np.zeros((1, n_karts, 2))
    fstate, istate = world.fstate[0], world.istate[0]
    pass_start = world.pass_start[0]

    def record(row: int) -> None:
        floats["distance"][row] = fstate[:, st.F_S]
        floats["wear"][row] = fstate[:, st.F_WEAR]
        floats["progress"][row] = world.total_progress()[0]
        for name, column in columns:
            ints[name][row] = istate[:, column]
        passes[row] = istate[:, st.I_PASSES]
        finished[row] = istate[:, st.I_FINISHED] != 0
        sim_xy[row] = fstate[:, st.F_X : st.F_Y + 1]

    record(0)
    grid = fstate[:, [st.F_X, st.F_Y, st.F_HEADING, st.F_SPEED]].copy()
    for step in range(n_steps):
        actions[0] = poses[step, :, 4:6]
        passed_before = istate[:, st.I_CP_PASSED].copy()
        starts_before = pass_start.copy()
        world.step(actions)
        row = step + 1
        record(row)
        crossings.extend(_crossings(passed_before, istate, fstate))
        incidents.extend(_incidents(row * DT, istate, fstate, passes[row] - passes[row - 1], starts_before, pass_start))
        if world.done[0]:
            for later in range(row + 1, n_steps + 1):
                record(later)  # (a finished world stands still; the replay may hold a few more rows)
            break

    recorded_xy = np.concatenate([sim_xy[:1], poses[:, :, 0:2]])
    pose_error = float(np.max(np.hypot(*(recorded_xy - sim_xy).transpose(2, 0, 1)))) if n_steps else 0.0
    finish_time = tuple(
        float(world.fstate[0, k, st.F_FINISH_TIME]) if world.istate[0, k, st.I_FINISHED] else None
        for k in range(n_karts)
    )
    pose_rows = np.concatenate([grid[None], poses[:, :, 0:4]])
    incidents.sort(key=lambda incident: (incident.time, incident.kart))
    crossings.sort(key=lambda crossing: (crossing.time, crossing.kart))
    return RaceTimeline(
        dt=DT,
        n_checkpoints=track.n_checkpoints,
        track_length=float(track.length),
        x=pose_rows[:, :, 0],
        y=pose_rows[:, :, 1],
        heading=pose_rows[:, :, 2],
        speed=pose_rows[:, :, 3],
        distance=floats["distance"],
        progress=floats["progress"],
        wear=floats["wear"],
        checkpoints_passed=ints["checkpoints_passed"],
        lane=ints["lane"],
        position=running_order(floats["progress"], finished, finish_time),
        collisions_at_fault=ints["collisions_at_fault"],
        illegal_lane_changes=ints["illegal_lane_changes"],
        wall_hits=ints["wall_hits"],
        passes=passes,
        finished=finished,
        finish_time=finish_time,
        crossings=tuple(crossings),
        incidents=tuple(incidents),
        pose_error=pose_error,
    )


def running_order(progress: np.ndarray, finished: np.ndarray, finish_time: tuple[float | None, ...]) -> np.ndarray:
    """1-based positions per row (steps, K): finished karts by finish time ahead of the others by progress,
    as :meth:`sim_core.world.World.standings` orders them."""
    times = np.array([t if t is not None else np.inf for t in finish_time])
    # finished karts sort first (by time), then the rest by progress, furthest first
    key = np.where(finished, times[None, :] - 1e12, -progress)
    order = np.argsort(key, axis=1, kind="stable")
    position = np.empty_like(order)
    rows = np.arange(order.shape[0])[:, None]
    position[rows, order] = np.arange(1, order.shape[1] + 1)[None, :]
    return position


def _crossings(passed_before: np.ndarray, istate: np.ndarray, fstate: np.ndarray) -> list[Crossing]:
    """The checkpoints each kart crossed in the step just taken (``passed_before``: its count before)."""
    return [
        Crossing(
            k,
            checkpoint,
            float(fstate[k, st.F_CROSS_TIME]),
            float(fstate[k, st.F_CROSS_SPEED]),
            float(fstate[k, st.F_CROSS_WEAR]),
        )
        for k in range(istate.shape[0])
        for checkpoint in range(int(passed_before[k]) + 1, int(istate[k, st.I_CP_PASSED]) + 1)
    ]


def _incidents(
    time: float,
    istate: np.ndarray,
    fstate: np.ndarray,
    new_passes: np.ndarray,
    starts_before: np.ndarray,
    starts_after: np.ndarray,
) -> list[Incident]:
    """What the referee judged in the step that ended at race time ``time`` (``new_passes``: passes counted
    in it per kart; ``starts_*``: the pending passes before and after it)."""
    found = []
    for k in range(istate.shape[0]):
        events = int(istate[k, st.I_EVENTS])
        for bit, kind in _EVENT_KINDS:
            if events & bit:
                other = _touched(k, istate, fstate) if kind == COLLISION_AT_FAULT else None
                found.append(Incident(time, k, kind, other))
        if new_passes[k] > 0:
            found.extend(_passes(k, starts_before, starts_after, int(new_passes[k])))
    return found


def _touched(kart: int, istate: np.ndarray, fstate: np.ndarray) -> int | None:
    """The nearest other kart that came into contact in this step (the other party of a collision)."""
    touching = [j for j in range(istate.shape[0]) if j != kart and istate[j, st.I_EVENTS] & st.EV_CONTACT]
    if not touching:
        return None
    x, y = fstate[kart, st.F_X], fstate[kart, st.F_Y]
    return min(touching, key=lambda j: float(np.hypot(fstate[j, st.F_X] - x, fstate[j, st.F_Y] - y)))


def _passes(kart: int, before: np.ndarray, after: np.ndarray, count: int) -> list[Incident]:
    """The passes ``kart`` completed in this step: its pending passes (``pass_start`` rows) that were cleared."""
    done = [o for o in range(before.shape[1]) if o != kart and before[kart, o] > 0 and after[kart, o] == 0]
    return [Incident(float(before[kart, o]) * DT, kart, PASS, o) for o in done[:count]]
