"""Each kart's lap times, read from a race's state after every step.

A lap ends when a kart's count of checkpoints passed reaches a multiple of the track's checkpoints; its end is
the time of that crossing, interpolated within the step (``F_CROSS_TIME``). The first lap runs from the start
(race time 0) and the last ends at the finish, so a finisher's lap times add up to its finish time (where every
kart races the same distance from its slot, its finish is off the line: its last lap ends there).
"""

from __future__ import annotations

from sim_core import state as st
from sim_core.world import World


class LapTimer:
    """Lap times of every kart of one race of a :class:`World`: call :meth:`observe` after every step."""

    def __init__(self, n_karts: int, n_checkpoints: int) -> None:
        self.n_checkpoints = n_checkpoints
        self._ends: list[list[float]] = [[] for _ in range(n_karts)]  # [s] race time at the end of each lap

    def observe(self, world: World, race: int = 0) -> None:
        """Note the laps completed in the last step."""
        for k, ends in enumerate(self._ends):
            if len(ends) == world.laps:
                continue
            laps = min(max(int(world.istate[race, k, st.I_CP_PASSED]), 0) // self.n_checkpoints, world.laps - 1)
            while len(ends) < laps:
                ends.append(float(world.fstate[race, k, st.F_CROSS_TIME]))
            if world.istate[race, k, st.I_FINISHED]:
                ends.append(float(world.fstate[race, k, st.F_FINISH_TIME]))

    def lap_times(self, kart: int) -> tuple[float, ...]:
        """[s] each completed lap's time, in order."""
        ends = self._ends[kart]
        starts = [0.0, *ends][: len(ends)]
        return tuple(end - start for start, end in zip(starts, ends, strict=True))

    def all_lap_times(self) -> tuple[tuple[float, ...], ...]:
        """:meth:`lap_times` of every kart, by kart index."""
        return tuple(self.lap_times(k) for k in range(len(self._ends)))
