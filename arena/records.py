"""The per-race figures the statistics read: one :class:`RaceFigures` per race, whoever ran it (a tournament of
ours, or the original implementation's logs, :mod:`arena.original_logs`).

A leaf module: dataclasses only, so the readers, the runner, the statistics and the reports share it.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field

# the two counting rules of illegal lane changes (sim_core.params.LANE_COUNTING_RULES): eqs. (10)-(11) as they
# happen ("per_step") and the original's sampling at checkpoints ("checkpoint", comparable with the paper)
PER_STEP = "per_step"
CHECKPOINT = "checkpoint"
COUNTING_RULES = (PER_STEP, CHECKPOINT)


@dataclass(frozen=True)
class KartFigures:
    """One kart's figures in one race (the paper's per-race columns).

    ``illegal_lane_changes`` holds the count under each counting rule the source measured (our races: both; the
    original's logs: ``checkpoint`` only). ``safety_score`` is collisions at fault plus the illegal lane changes
    under ``safety_rule``.
    """

    agent: str  # registry name (mcts-rl, e2e, fixed-rl, mcts-lqng, fixed-lqng, ...)
    finished: bool  # completed every lap
    total_time: float | None  # [s] race time at the finish (None: did not finish)
    collisions_at_fault: int
    illegal_lane_changes: Mapping[str, int]  # counting rule -> count
    safety_rule: str  # the counting rule inside safety_score
    passes: int | None = None  # overtakes completed and held (None: not measured by the source)
    delta_r: float | None = None  # [m] mean target-lane distance at checkpoints (None: no plan)
    delta_v: float | None = None  # [m/s] mean target-speed difference at checkpoints (None: no plan)
    contacts_with: tuple[int, ...] | None = None  # contacts with each kart of the race, by kart (None: not recorded)
    passes_of: tuple[int, ...] | None = None  # passes of each kart of the race, by kart (None: not recorded)

    @property
    def safety_score(self) -> int:
        """Collisions at fault + illegal lane changes (under ``safety_rule``): the paper's safety score."""
        return self.collisions_at_fault + self.illegal_lane_changes[self.safety_rule]


@dataclass(frozen=True)
class RaceFigures:
    """One head-to-head race: its track and both karts' figures (kart 0 first)."""

    track: str
    karts: tuple[KartFigures, ...]
    index: int = 0  # position in its tournament's schedule (or in the log file)
    seed: int | None = None
    start_lanes: tuple[int, ...] | None = None
    conditions: str | None = None  # the race conditions' set (None: not known, e.g. the original's logs)
    duration: float | None = None  # [s] simulated race time
    race_id: str | None = None  # where the race is stored (None: not stored)
    teams: tuple[str, ...] | None = None  # each kart's team (None: every kart for itself; :mod:`arena.teams`)
    extra: Mapping[str, object] = field(default_factory=dict)

    @property
    def agents(self) -> tuple[str, ...]:
        """The karts' agents, kart 0 first."""
        return tuple(k.agent for k in self.karts)

    def winner(self) -> str | None:
        """The paper's win rule: a kart wins only if it completed every lap; among finishers the lower total time
        wins; nobody wins if nobody finished (:func:`winner_index`)."""
        index = winner_index(self.karts)
        return None if index is None else self.karts[index].agent


def winner_index(karts: tuple[KartFigures, ...]) -> int | None:
    """Index of the winning kart under the paper's win rule, or ``None`` when no kart finished. Equal times: the
    lower index (never seen in the data; the rule needs a tie-break to be a function)."""
    finishers = [(k.total_time, i) for i, k in enumerate(karts) if k.finished and k.total_time is not None]
    return min(finishers)[1] if finishers else None
