"""What a controller sees: a frozen snapshot of every kart plus the ego kart's rays, taken from a World.

Data flows one way: World -> Observation -> controller -> action -> World.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from sim_core import state as st
from sim_core.world import World


@dataclass(frozen=True)
class KartView:
    """One kart as observed: pose, speed, progress, and its state at the last checkpoint crossing."""

    index: int
    x: float  # [m]
    y: float  # [m]
    heading: float  # [rad]
    speed: float  # [m/s]
    progress: float  # [m] along the centre line within the lap
    lateral: float  # [m] left-positive offset from the centre line
    wear: float  # [-]
    checkpoints_passed: int  # absolute count since the start
    lane: int  # lane at the last crossing (1-based)
    lane_changes: int  # eq. (10) counter sampled at checkpoint crossings
    crossing_time: float  # [s] race time of the last crossing
    crossing_speed: float  # [m/s]
    crossing_wear: float  # [-]
    finished: bool
    lane_now: int = 0  # lane the kart is in now, with the referee's hysteresis (0: unknown)
    lane_changes_now: int = 0  # eq. (10) counter as lane changes happen (the per-step rule's)


@dataclass(frozen=True)
class Observation:
    """Everything a controller may use for one decision of kart ``ego``."""

    time: float  # [s] race time
    ego: int
    karts: tuple[KartView, ...]
    ray_distances: np.ndarray  # (9,) [m]
    ray_hits: np.ndarray  # (9,) sim_core.state.HIT_*

    @property
    def me(self) -> KartView:
        """The ego kart."""
        return self.karts[self.ego]

    def others(self) -> tuple[KartView, ...]:
        """Every other kart still racing."""
        return tuple(k for k in self.karts if k.index != self.ego and not k.finished)


def kart_views(world: World, race: int) -> tuple[KartView, ...]:
    """Views of every kart of ``race``."""
    # one conversion of the race's rows to Python numbers (what float() and int() of each entry give)
    floats, ints = world.fstate[race].tolist(), world.istate[race].tolist()
    return tuple(
        KartView(
            k,
            f[st.F_X],
            f[st.F_Y],
            f[st.F_HEADING],
            f[st.F_SPEED],
            f[st.F_S],
            f[st.F_D],
            f[st.F_WEAR],
            i[st.I_CP_PASSED],
            i[st.I_LANE],
            i[st.I_LANE_COUNT],
            f[st.F_CROSS_TIME],
            f[st.F_CROSS_SPEED],
            f[st.F_CROSS_WEAR],
            bool(i[st.I_FINISHED]),
            i[st.I_LANE_NOW],
            i[st.I_STEP_LANE_COUNT],
        )
        for k, (f, i) in enumerate(zip(floats, ints, strict=True))
    )


def observe(world: World, race: int = 0) -> list[Observation]:
    """One observation per kart of ``race`` (they share the kart views)."""
    views = kart_views(world, race)
    time = float(world.time[race])
    return [
        Observation(time, k, views, world.ray_dist[race, k].copy(), world.ray_hit[race, k].copy())
        for k in range(world.n_karts)
    ]


def place_view(world: World, race: int, slot: int, view: KartView, steer: float = 0.0) -> None:
    """Put kart ``slot`` of ``race`` where ``view`` saw a kart: pose, speed, tyre wear, checkpoint count, lanes and
    lane-change counters (what a planner races forward from; the kart's other counters start at zero).

    The view has no steering or slip: the kart starts steering ``steer`` in [-1, 1], with the slip that steer holds
    in a steady turn (:func:`sim_core.kart.kart_step`), so a kart seen mid-corner does not start straight ahead."""
    track = world.track
    _, tangent = track.point_at(view.progress)
    heading_offset = math.remainder(view.heading - math.atan2(float(tangent[1]), float(tangent[0])), 2.0 * math.pi)
    world.place_kart(
        race, slot, s=view.progress, d=view.lateral, heading_offset=heading_offset, speed=view.speed, wear=view.wear
    )
    f, i = world.fstate[race, slot], world.istate[race, slot]
    f[st.F_STEER] = steer
    f[st.F_SLIP] = math.atan(0.5 * math.tan(steer * world.params.kart.max_steer_angle))
    f[st.F_CROSS_TIME] = view.crossing_time
    f[st.F_CROSS_SPEED] = view.crossing_speed
    f[st.F_CROSS_WEAR] = view.crossing_wear
    i[st.I_CP_PASSED] = view.checkpoints_passed
    i[st.I_LANE] = view.lane
    i[st.I_LANE_COUNT] = view.lane_changes
    i[st.I_LANE_NOW] = view.lane_now or view.lane
    i[st.I_STEP_LANE_COUNT] = view.lane_changes_now
    i[st.I_FINISHED] = int(view.finished)
