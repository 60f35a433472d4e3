"""Opponent models for the tactical game, chosen per kart by how well each has forecast that kart (ours).

The discrete game (paper section 4.1) needs a move for every other kart. The paper's search plays every
player's best response; a line follower is better predicted by its line, a kart that holds a lane by that
lane, and a learned policy that drives its own line by the lap it drove last. Nothing tells a planner which
driver is which, so it measures: at every plan each candidate model forecasts each kart's lane at its next
checkpoints, and when the kart crosses them the forecasts are scored. The game then plays each kart by the
model with the fewest missed lanes so far (:class:`OpponentModelSelector`). No model knows which controller
drives a kart; a registered controller's own lap is one candidate (:class:`SimulatedDriver`) and is only used
for a kart it forecasts best.

Every model gives the game a lane per checkpoint (:class:`GameModel`); the kart's section times come from
its pace measured in the race (:mod:`controllers.tactical.pace`), the same for every model.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import Protocol

import numpy as np

from controllers.base import Controller, RaceContext
from controllers.tactical import rules
from sim_core.observation import KartView, observe
from sim_core.params import DT
from sim_core.state import I_CP_PASSED, I_LANE
from sim_core.track import Track
from sim_core.world import World

# a kart's best response in the game: its 1-based lane at each (absolute) checkpoint the game plays it to
BestResponse = Callable[[int], dict[int, int]]


@dataclass(frozen=True)
class GameModel:
    """How the game plays a kart: a :mod:`~controllers.tactical.rules` ``MODEL_*`` code, and for
    ``MODEL_SCRIPT`` its 0-based lane at each checkpoint of a lap (-1: no lane there, it plays freely)."""

    code: int
    lanes: tuple[int, ...] = ()


class OpponentModel(Protocol):
    """A forecast of where another kart drives: its lane at upcoming checkpoints."""

    name: str

    def reset(self, track: Track, line_lanes: tuple[int, ...]) -> None:
        """Prepare for a race on ``track`` whose racing line takes ``line_lanes`` (1-based, per checkpoint)."""

    def record(self, kart: KartView) -> None:
        """Note the kart's last checkpoint crossing (a model that learns from the race keeps it)."""

    def forecast(self, kart: KartView, checkpoints: Sequence[int], best_response: BestResponse) -> dict[int, int]:
        """The kart's 1-based lane at each of ``checkpoints`` (absolute) the model has a lane for."""

    def in_game(self, kart: KartView) -> GameModel:
        """How the game should play the kart under this model."""


class RacingLine:
    """A line follower: the offline racing line's lane at every checkpoint."""

    name = "racing-line"

    def __init__(self) -> None:
        self._lanes: tuple[int, ...] = ()

    def reset(self, track: Track, line_lanes: tuple[int, ...]) -> None:
        """Keep the line's lanes."""
        self._lanes = line_lanes

    def record(self, kart: KartView) -> None:
        """Nothing to learn."""

    def forecast(self, kart: KartView, checkpoints: Sequence[int], best_response: BestResponse) -> dict[int, int]:
        """The line's lane at each checkpoint."""
        return {c: self._lanes[c % len(self._lanes)] for c in checkpoints}

    def in_game(self, kart: KartView) -> GameModel:
        """The game's line follower."""
        return GameModel(rules.MODEL_LINE)


class HoldsLane:
    """Constant lane: the kart stays in the lane it is in now (at its measured pace)."""

    name = "holds-lane"

    def __init__(self) -> None:
        self._track: Track | None = None

    def reset(self, track: Track, line_lanes: tuple[int, ...]) -> None:
        """Keep the track (lane ids from lateral offsets)."""
        self._track = track

    def record(self, kart: KartView) -> None:
        """Nothing to learn."""

    def forecast(self, kart: KartView, checkpoints: Sequence[int], best_response: BestResponse) -> dict[int, int]:
        """The lane it is in now (at its next checkpoint's lane boundaries) everywhere."""
        assert self._track is not None, "reset() first"
        lane = self._track.lane_id(max(kart.checkpoints_passed, 0) + 1, kart.lateral)
        return dict.fromkeys(checkpoints, lane)

    def in_game(self, kart: KartView) -> GameModel:
        """The game holds the player's lane."""
        return GameModel(rules.MODEL_HOLD)


class BestResponder:
    """The tactical game's own prediction: the kart plays its best response (the paper's search of every
    player)."""

    name = "game"

    def reset(self, track: Track, line_lanes: tuple[int, ...]) -> None:
        """Nothing to prepare."""

    def record(self, kart: KartView) -> None:
        """Nothing to learn."""

    def forecast(self, kart: KartView, checkpoints: Sequence[int], best_response: BestResponse) -> dict[int, int]:
        """The lanes of the kart's fastest play in the game from the present state."""
        lanes = best_response(kart.index)
        return {c: lanes[c] for c in checkpoints if c in lanes}

    def in_game(self, kart: KartView) -> GameModel:
        """The game searches the player's moves."""
        return GameModel(rules.MODEL_FREE)


@dataclass
class OwnLastLap:
    """A driver that repeats itself: at each checkpoint, the lane the kart took there a lap ago.

    Crossings are seen when the planner looks (about once a second), so some are missed; a missed one takes
    the lane of the kart's last crossing before it on that lap."""

    name: str = "own-last-lap"
    max_gap: int = 3  # checkpoints back a missed crossing may take its lane from
    _n: int = 0
    _seen: dict[int, dict[int, int]] = field(default_factory=dict)  # kart -> absolute checkpoint -> lane

    def reset(self, track: Track, line_lanes: tuple[int, ...]) -> None:
        """Forget every kart's crossings."""
        self._n = track.n_checkpoints
        self._seen = {}

    def record(self, kart: KartView) -> None:
        """Keep the lane of the kart's last crossing."""
        if kart.checkpoints_passed > 0:
            self._seen.setdefault(kart.index, {})[kart.checkpoints_passed] = kart.lane

    def _lane(self, kart: int, checkpoint: int) -> int | None:
        seen = self._seen.get(kart, {})
        for back in range(self.max_gap + 1):
            lane = seen.get(checkpoint - self._n - back)
            if lane is not None:
                return lane
        return None

    def forecast(self, kart: KartView, checkpoints: Sequence[int], best_response: BestResponse) -> dict[int, int]:
        """The lanes of a lap ago, where seen."""
        lanes = {c: self._lane(kart.index, c) for c in checkpoints}
        return {c: lane for c, lane in lanes.items() if lane is not None}

    def in_game(self, kart: KartView) -> GameModel:
        """The game scripts the player's lanes from the lap it drove last (none yet: it plays freely)."""
        start = max(kart.checkpoints_passed, 0) + 1
        lanes = [-1] * self._n
        for c in range(start, start + self._n):
            lane = self._lane(kart.index, c)
            if lane is not None:
                lanes[c % self._n] = lane - 1
        return GameModel(rules.MODEL_SCRIPT, tuple(lanes))


AgentFactory = Callable[[str], Controller]  # a new controller from an agent string (the registry's make_agent)


class SimulatedDriver:
    """A registered controller simulated forward: its lane at every checkpoint of a lap driven alone on the
    race's track (simulated once per track and controller; a pace handicap drives the same path)."""

    def __init__(self, agent: str, build: AgentFactory) -> None:
        self.agent = agent
        self.name = f"{SIMULATED_PREFIX}{agent}"
        self._build = build
        self._lanes: tuple[int, ...] = ()

    def reset(self, track: Track, line_lanes: tuple[int, ...]) -> None:
        """Simulate the controller's lap (or take it from the cache)."""
        self._lanes = solo_lap_lanes(track, self.agent, self._build)

    def record(self, kart: KartView) -> None:
        """Nothing to learn."""

    def forecast(self, kart: KartView, checkpoints: Sequence[int], best_response: BestResponse) -> dict[int, int]:
        """The simulated lap's lane at each checkpoint."""
        return {c: self._lanes[c % len(self._lanes)] for c in checkpoints}

    def in_game(self, kart: KartView) -> GameModel:
        """The game scripts the player's lanes from the simulated lap."""
        return GameModel(rules.MODEL_SCRIPT, tuple(lane - 1 for lane in self._lanes))


_SOLO_LAPS: dict[tuple[str, int, str], tuple[int, ...]] = {}
SOLO_LAP_TIME_LIMIT = 600.0  # [s] of race time: a controller that cannot drive two laps alone gives what it drove


def solo_lap_lanes(track: Track, agent: str, build: AgentFactory) -> tuple[int, ...]:
    """The 1-based lane ``agent`` (built by ``build``) crosses each checkpoint of ``track`` in on its second lap
    alone (the first starts from the grid; a checkpoint it never crossed: lane 1), without imprecision. Kept per
    track and agent for the life of the process."""
    key = (track.name, track.n_checkpoints, agent)
    if key not in _SOLO_LAPS:
        world = World(track, 1, 1, laps=2, sensors=True)
        driver = build(agent)
        driver.reset(RaceContext(track, world.kart_params(0, 0), 0, 1, world.lane_change_limit, 0))
        hold = max(1, round(1.0 / (DT * driver.rate_hz)))
        actions = np.zeros((1, 1, 2))
        crossings: dict[int, int] = {}
        for step in range(round(SOLO_LAP_TIME_LIMIT / DT)):
            if world.done[0]:
                break
            if step % hold == 0:
                action = driver.act(observe(world, 0)[0])
                actions[0, 0] = (action.steer, action.throttle)
            world.step(actions)
            crossings[int(world.istate[0, 0, I_CP_PASSED])] = int(world.istate[0, 0, I_LANE])
        n = track.n_checkpoints
        _SOLO_LAPS[key] = tuple(crossings.get(n + c, crossings.get(c, 1)) for c in range(n))
    return _SOLO_LAPS[key]


MODELS: dict[str, Callable[[], OpponentModel]] = {
    RacingLine.name: RacingLine,
    HoldsLane.name: HoldsLane,
    BestResponder.name: BestResponder,
    "own-last-lap": OwnLastLap,
}
SIMULATED_PREFIX = "simulated-"  # simulated-fixed-lqng: the registered fixed-lqng simulated forward


def make_model(name: str, build: AgentFactory | None = None) -> OpponentModel:
    """The model called ``name``: one of :data:`MODELS` or ``simulated-AGENT`` (an agent string, which ``build``
    makes)."""
    if name.startswith(SIMULATED_PREFIX):
        if build is None:
            raise ValueError(f"opponent model {name!r} needs an agent factory")
        return SimulatedDriver(name[len(SIMULATED_PREFIX) :], build)
    if name not in MODELS:
        raise ValueError(f"unknown opponent model {name!r}; known: {', '.join(MODELS)} or {SIMULATED_PREFIX}AGENT")
    return MODELS[name]()


MODEL_SEPARATOR = "+"  # between the model names of an agent parameter (commas separate agents in a list)
ADAPTIVE_MODELS = MODEL_SEPARATOR.join(
    ("racing-line", "holds-lane", "game", "own-last-lap", "simulated-fixed-lqng", "simulated-fixed-rl")
)


def model_names(value: str) -> tuple[str, ...]:
    """The model names of an agent parameter's ``value`` (``racing-line+holds-lane``), each checked."""
    names = tuple(name.strip() for name in value.split(MODEL_SEPARATOR) if name.strip())
    if not names:
        raise ValueError("at least one opponent model")
    for name in names:
        if not name.startswith(SIMULATED_PREFIX):
            make_model(name)
    return names


@dataclass
class _Score:
    error: float = 0.0  # running share of forecast lanes missed
    samples: int = 0


@dataclass
class OpponentModelSelector:
    """Chooses each kart's model by its measured forecast error.

    At every look (:meth:`observe`) each model forecasts each kart's lanes ``lookahead`` checkpoints beyond its
    next one (the first forecast of a checkpoint is kept: made a second or more ahead). When the kart is seen
    past a forecast checkpoint, a model scores 1 if it named another lane, else 0, into a running mean that
    forgets by ``memory`` per sample. A kart is played by the first model (the prior) until a model has
    ``min_samples``; then by the model of least error among those, changed only for one better by
    ``switch_margin``.
    """

    models: tuple[OpponentModel, ...]
    lookahead: int = 4
    memory: float = 0.85
    min_samples: int = 4
    switch_margin: float = 0.1
    _scores: dict[tuple[int, str], _Score] = field(default_factory=dict)
    _pending: dict[tuple[int, str], dict[int, int]] = field(default_factory=dict)
    _chosen: dict[int, int] = field(default_factory=dict)
    _last_seen: dict[int, int] = field(default_factory=dict)

    def __post_init__(self) -> None:
        if not self.models:
            raise ValueError("at least one opponent model")

    @classmethod
    def of(cls, names: Sequence[str], build: AgentFactory | None = None) -> OpponentModelSelector:
        """A selector over the models called ``names`` (the first is the prior; ``build`` makes the agents of
        ``simulated-AGENT`` models)."""
        return cls(tuple(make_model(name, build) for name in names))

    @property
    def names(self) -> tuple[str, ...]:
        """The candidate models' names, the prior first."""
        return tuple(m.name for m in self.models)

    def reset(self, track: Track, line_lanes: tuple[int, ...]) -> None:
        """Forget every score and forecast; reset the models."""
        for model in self.models:
            model.reset(track, line_lanes)
        self._scores, self._pending, self._chosen, self._last_seen = {}, {}, {}, {}

    def score(self, karts: Sequence[KartView]) -> None:
        """Score the forecasts of every kart seen past a forecast checkpoint, let the models record its crossing,
        and update its choice."""
        for kart in karts:
            passed = kart.checkpoints_passed
            if kart.finished or passed <= self._last_seen.get(kart.index, 0):
                continue
            self._last_seen[kart.index] = passed
            for model in self.models:
                model.record(kart)
                pending = self._pending.get((kart.index, model.name), {})
                predicted = pending.pop(passed, None)
                for c in [c for c in pending if c < passed]:
                    del pending[c]
                if predicted is None:
                    continue
                s = self._scores.setdefault((kart.index, model.name), _Score())
                s.error = self.memory * s.error + (1.0 - self.memory) * float(predicted != kart.lane)
                s.samples += 1
            self._choose(kart.index)

    def _choose(self, kart: int) -> None:
        errors = self.errors(kart, self.min_samples)
        if not errors:
            return
        current = self.model_of(kart).name
        best = min(errors, key=errors.__getitem__)
        # a model not yet measured enough (the prior included) gives way to any that is
        if current not in errors or errors[best] < errors[current] - self.switch_margin:
            self._chosen[kart] = self.names.index(best)

    def forecast(self, karts: Sequence[KartView], best_response: BestResponse) -> None:
        """Every model's forecast of each kart's lanes beyond its next checkpoint (the first one kept)."""
        for kart in karts:
            if kart.finished:
                continue
            nearest = max(kart.checkpoints_passed, 0) + 2
            checkpoints = range(nearest, nearest + self.lookahead)
            for model in self.models:
                pending = self._pending.setdefault((kart.index, model.name), {})
                for c, lane in model.forecast(kart, checkpoints, best_response).items():
                    pending.setdefault(c, lane)

    def model_of(self, kart: int) -> OpponentModel:
        """The model the game plays ``kart`` by now."""
        return self.models[self._chosen.get(kart, 0)]

    def errors(self, kart: int, min_samples: int = 1) -> dict[str, float]:
        """Each model's running share of missed lanes for ``kart`` (bias-corrected for the running mean's start;
        models with fewer than ``min_samples`` left out)."""
        out = {}
        for m in self.models:
            s = self._scores.get((kart, m.name))
            if s is not None and s.samples >= min_samples:
                out[m.name] = s.error / (1.0 - self.memory**s.samples)
        return out
