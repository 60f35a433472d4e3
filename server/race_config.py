"""What a race is started from: its track, laps, seed and karts (each a display name, a controller and its
parameters). Built once from a validated request (:mod:`server.routes.races`), stored with the race, read back."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

from controllers.base import RaceContext, team_numbers
from sim_core.conditions import RaceConditions, condition_set
from sim_core.params import SimParams
from sim_core.track import Track
from sim_core.world import World

HUMAN = "human"  # the controller name of a kart driven over the drive websocket

ParamValue = bool | int | float | str  # a controller parameter's value, as a race request gives it


@dataclass(frozen=True)
class KartEntry:
    """One kart of a race: grid slot, display name, controller (registered name or ``human``) and the
    controller's parameters that differ from its defaults, and the kart's pace handicap
    (:meth:`sim_core.params.KartParams.paced`: 1 is the race's kart, 0.95 one 5% slower on the same line)."""

    index: int
    name: str
    controller: str
    params: Mapping[str, ParamValue] = field(default_factory=dict)
    pace: float = 1.0
    team: str | None = None  # karts with the same team race together (None: for itself)

    @property
    def human(self) -> bool:
        """Whether a person (or a client program) drives this kart over the websocket."""
        return self.controller == HUMAN

    def to_json(self) -> dict[str, Any]:
        """``{index, name, controller, params, pace, team}`` (as stored with the race)."""
        return {
            "index": self.index,
            "name": self.name,
            "controller": self.controller,
            "params": dict(self.params),
            "pace": self.pace,
            "team": self.team,
        }

    @classmethod
    def from_json(cls, data: Mapping[str, Any]) -> KartEntry:
        """Read back :meth:`to_json` (races stored before parameters, paces or teams existed have none, pace 1)."""
        params = dict(data.get("params") or {})
        team = data.get("team")
        return cls(
            int(data["index"]),
            str(data["name"]),
            str(data["controller"]),
            params,
            float(data.get("pace", 1.0)),
            None if team is None else str(team),
        )


@dataclass(frozen=True)
class RaceConfig:
    """Everything a race is started from (already validated)."""

    track_name: str
    track: Track
    laps: int
    seed: int
    start_lanes: tuple[int, ...] | None
    kart_preset: str
    karts: tuple[KartEntry, ...]
    conditions: str = "paper"  # the race conditions' set (sim_core.conditions), drawn from the seed

    def drawn(self) -> RaceConditions:
        """This race's conditions, drawn from its seed (:meth:`sim_core.conditions.ConditionSet.draw`)."""
        return condition_set(self.conditions).draw(self.seed, len(self.karts), self.start_lanes)


def kart_paces(karts: Sequence[KartEntry], drawn_paces: Sequence[float], humans: Sequence[bool]) -> tuple[float, ...]:
    """Each kart's pace: its handicap (a human's too), an AI kart's times the pace the conditions drew for it."""
    return tuple(k.pace * (1.0 if human else drawn) for k, drawn, human in zip(karts, drawn_paces, humans, strict=True))


def build_world(config: RaceConfig, params: SimParams, drawn: RaceConditions, humans: Sequence[bool]) -> World:
    """The race's one-race world on its grid: the drawn start wear and offsets, and each kart at its pace
    (:func:`kart_paces`)."""
    world = World(config.track, 1, len(config.karts), params, laps=config.laps)
    paces = kart_paces(config.karts, drawn.paces, humans)
    world.reset(
        start_lanes=config.start_lanes,
        wear=drawn.start_wear,
        start_offsets=drawn.start_offsets,
        paces=paces,
        finish=drawn.finish,
    )
    return world


def driver_context(config: RaceConfig, world: World, kart: int) -> RaceContext:
    """What the driver of ``kart`` learns at the start: the track, its kart at its pace, and its seed."""
    context = RaceContext(
        config.track,
        world.kart_params(0, kart),
        kart,
        len(config.karts),
        world.lane_change_limit,
        config.seed * 1000 + kart,
        float(world.paces[0, kart]),
        team_numbers([k.team for k in config.karts]),
    )
    return context
