"""The tactics suite's scenarios as data (:mod:`arena.scenarios` races them): a :class:`Scenario` is a JSON file,
a shipped one in ``scenarios/`` or a user's own, and a :class:`Cell` one (scenario, track, ego, opponent, pace) of
it. The kinds and what each measures: :mod:`arena.scenarios`."""

from __future__ import annotations

import json
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Any, Literal

from controllers.registry import PACE_SEPARATOR, validate_agent
from sim_core.conditions import CONDITION_SETS
from sim_core.params import MIN_PACE
from sim_core.world import DEFAULT_START_LANES

SCENARIO_DIR = Path(__file__).resolve().parent.parent / "scenarios"
Kind = Literal["overtake", "defend", "side-by-side", "lapping", "start"]
KINDS: tuple[Kind, ...] = ("overtake", "defend", "side-by-side", "lapping", "start")
TWO_KART_KINDS: tuple[Kind, ...] = ("overtake", "defend", "side-by-side")  # the ego and one opponent
Place = Literal["straight", "corner"]
PLACES: tuple[Place, ...] = ("straight", "corner")
ABREAST_M = 3.0  # [m] side by side: the ego at most this far ahead of or behind the opponent


@dataclass(frozen=True)
class Scenario:
    """One tactical situation, raced from placed karts (see the module notes)."""

    name: str
    kind: Kind
    description: str = ""
    tracks: tuple[str, ...] = ("oval", "complex")
    place: Place = "straight"
    # [m] uniform per attempt: between the two karts (side by side: the ego behind the opponent, negative: ahead)
    gap_m: tuple[float, float] = (10.0, 20.0)
    # the paced kart's pace: overtake, the leader's; defend, the ego's; lapping, the slower kart's; otherwise the
    # opponent's
    paces: tuple[float, ...] = (0.90, 0.93, 0.95, 0.97, 0.99)
    laps: int = 3  # from the placement; a pass must be done within them
    conditions: str = "varied"
    backmarker: str = "fixed-lqng"  # lapping: the slower kart's agent
    rival_gap_m: tuple[float, float] = (3.0, 6.0)  # [m] lapping: the opponent behind the ego, uniform per attempt
    karts: int = 4  # start: the field (the ego and copies of the opponent), one per grid lane

    def __post_init__(self) -> None:
        problems = self.problems()
        if problems:
            raise ValueError(f"scenario {self.name!r}: " + "; ".join(problems))

    def problems(self) -> list[str]:
        """What is wrong with it (empty: nothing)."""
        found = []
        if self.kind not in KINDS:
            found.append(f"kind must be one of {list(KINDS)}, got {self.kind!r}")
        if self.place not in PLACES:
            found.append(f"place must be one of {list(PLACES)}, got {self.place!r}")
        low, high = self.gap_m
        if self.kind == "side-by-side":
            if not -ABREAST_M <= low <= high <= ABREAST_M:
                found.append(f"gap_m must be -{ABREAST_M:g} <= low <= high <= {ABREAST_M:g} m, got {list(self.gap_m)}")
        elif not 2.5 <= low <= high <= 60.0:
            found.append(f"gap_m must be 2.5 <= low <= high <= 60 m, got {list(self.gap_m)}")
        if not self.paces or any(not MIN_PACE <= p <= 1.0 for p in self.paces):
            found.append(f"paces must be in [{MIN_PACE}, 1], got {list(self.paces)}")
        if not 1 <= self.laps <= 5:
            found.append(f"laps must be in 1..5, got {self.laps}")
        if self.conditions not in CONDITION_SETS:
            found.append(f"conditions must be one of {sorted(CONDITION_SETS)}, got {self.conditions!r}")
        if not self.tracks:
            found.append("tracks must name at least one track")
        found += self._kind_problems()
        return found

    def _kind_problems(self) -> list[str]:
        found = []
        if self.kind == "lapping":
            low, high = self.rival_gap_m
            if not 2.5 <= low <= high <= 60.0:
                found.append(f"rival_gap_m must be 2.5 <= low <= high <= 60 m, got {list(self.rival_gap_m)}")
            try:
                validate_agent(self.backmarker)
            except (KeyError, ValueError) as error:
                found.append(f"backmarker: {error}")
            if PACE_SEPARATOR in self.backmarker:
                found.append(f"backmarker {self.backmarker!r} carries its own pace: the scenario's paces set it")
        if self.kind == "start" and not 2 <= self.karts <= len(DEFAULT_START_LANES):
            found.append(f"karts must be in 2..{len(DEFAULT_START_LANES)} (one per grid lane), got {self.karts}")
        return found

    @classmethod
    def from_json(cls, data: dict[str, Any]) -> Scenario:
        """A scenario from its file's object (``ValueError`` naming what is wrong)."""
        unknown = set(data) - {f for f in cls.__dataclass_fields__}
        if unknown:
            raise ValueError(f"scenario {data.get('name')!r}: unknown fields {sorted(unknown)}")
        values = dict(data)
        for name in ("tracks", "gap_m", "paces", "rival_gap_m"):
            if name in values:
                values[name] = tuple(values[name])
        return cls(**values)

    def to_json(self) -> dict[str, Any]:
        """Every field, as its file holds it."""
        return {k: list(v) if isinstance(v, tuple) else v for k, v in asdict(self).items()}


def load_scenario(name_or_path: str) -> Scenario:
    """A shipped scenario by name, or a scenario file by path (``KeyError`` naming the shipped ones)."""
    path = Path(name_or_path)
    if not path.suffix:
        path = SCENARIO_DIR / f"{name_or_path}.json"
        if not path.is_file():
            raise KeyError(f"unknown scenario {name_or_path!r}; shipped: {shipped_scenarios()}")
    return Scenario.from_json(json.loads(path.read_text()))


def shipped_scenarios() -> list[str]:
    """Names of the scenarios in ``scenarios/``."""
    return sorted(p.stem for p in SCENARIO_DIR.glob("*.json"))


@dataclass(frozen=True)
class Cell:
    """One cell of a scenario: the ego against the opponent on a track, the paced kart at ``pace``."""

    scenario: str
    track: str
    ego: str
    opponent: str
    pace: float

    def agents(self, kind: Kind) -> tuple[str, str]:
        """(ego, opponent) agent strings with the pace on the kart it handicaps (lapping: on neither, the slower
        kart is :meth:`paced`)."""
        if kind == "defend":
            return with_pace(self.ego, self.pace), self.opponent
        if kind == "lapping":
            return with_pace(self.ego, 1.0), with_pace(self.opponent, 1.0)
        return self.ego, with_pace(self.opponent, self.pace)

    def paced(self, agent: str) -> str:
        """``agent`` at the cell's pace."""
        return with_pace(agent, self.pace)


def with_pace(agent: str, pace: float) -> str:
    """``agent`` at ``pace`` (``agent`` itself at pace 1; ``ValueError`` if it already carries one)."""
    if PACE_SEPARATOR in agent:
        raise ValueError(f"agent {agent!r} carries its own pace: a scenario sets it")
    return agent if pace == 1.0 else f"{agent}{PACE_SEPARATOR}{pace:g}"
