"""Each kart's pace, measured in the race: the opponent model's speed (ours, not the paper's).

The discrete game times every player by one model of the kart, calibrated to the racing line's speed profile
(:mod:`controllers.tactical.calibration`). The karts on track are not that model: the LQNG tracker laps
``complex`` 5-10% over the line's predicted lap and the RL trackers 3-4%, so a kart behind a slower one
sees no time to gain by going past it and follows it home (``mcts-rl`` 3.5 s a race faster alone than
``mcts-lqng``, 0.6 s behind it at the flag). A kart's pace is its observed time over the sections it
crossed in clean air, over the line's predicted time for the same sections, forgetting old sections
geometrically; the game multiplies the player's section times by it (:data:`controllers.tactical.rules.PACE`).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from controllers.racing_line import RacingLine
from controllers.tactical.calibration import line_sample_sections, section_times
from sim_core.observation import KartView
from sim_core.track import Track

PACE_RANGE = (0.8, 1.3)  # a measured pace is clipped to this (a spin or a wall contact is not a pace)


def line_section_times(track: Track, line: RacingLine) -> np.ndarray:
    """(N,) time [s] the racing line's speed profile takes through each section (checkpoint c to c + 1)."""
    sections = line_sample_sections(track, line)
    return section_times(np.asarray(line.xy), np.asarray(line.speed), sections, track.n_checkpoints)


@dataclass
class _Crossing:
    checkpoints: int  # checkpoints passed
    time: float  # [s] race time of the last crossing
    clean: bool  # nobody was close ahead when it was seen


@dataclass
class PaceMeter:
    """Running pace of every kart of a race, updated from observations (:meth:`observe`).

    A stretch between two observed crossings counts when the kart had nobody within ``clean_gap`` [m] ahead
    along the track at both observations and had passed ``skip_checkpoints`` (the standing start is not a
    flying lap); sums decay by ``memory`` per counted stretch. A kart with under ``min_seconds`` of counted model
    time has no pace yet (:meth:`pace` returns the fallback)."""

    section_time: np.ndarray  # (N,) [s] the line's time per section
    clean_gap: float = 20.0
    skip_checkpoints: int = 4
    memory: float = 0.9
    min_seconds: float = 4.0
    _last: dict[int, _Crossing] = field(default_factory=dict)
    _observed: dict[int, float] = field(default_factory=dict)
    _modelled: dict[int, float] = field(default_factory=dict)

    @classmethod
    def of(cls, track: Track, line: RacingLine) -> PaceMeter:
        """A meter for ``track`` timed against ``line``."""
        return cls(line_section_times(track, line))

    def observe(self, karts: tuple[KartView, ...], track: Track) -> None:
        """Count the sections each kart crossed since the previous observation."""
        n = len(self.section_time)
        for kart in karts:
            if kart.finished:
                continue
            clean = all(
                other.index == kart.index or not 0.0 < track.gap(kart.progress, other.progress) < self.clean_gap
                for other in karts
            )
            now = _Crossing(kart.checkpoints_passed, kart.crossing_time, clean)
            before = self._last.get(kart.index)
            self._last[kart.index] = now
            if before is None or now.checkpoints <= before.checkpoints or not (before.clean and now.clean):
                continue
            if before.checkpoints < self.skip_checkpoints:
                continue
            sections = np.arange(before.checkpoints, now.checkpoints) % n
            modelled = float(self.section_time[sections].sum())
            observed = now.time - before.time
            if modelled <= 0.0 or observed <= 0.0:
                continue
            self._observed[kart.index] = self.memory * self._observed.get(kart.index, 0.0) + observed
            self._modelled[kart.index] = self.memory * self._modelled.get(kart.index, 0.0) + modelled

    def pace(self, kart: int, fallback: float) -> float:
        """The kart's measured pace (observed over modelled time), or ``fallback`` before it has one."""
        if kart not in self._modelled or self._modelled[kart] < self.min_seconds:
            return fallback
        return float(np.clip(self._observed[kart] / self._modelled[kart], *PACE_RANGE))
