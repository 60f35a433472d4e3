"""Race conditions: how a race starts and what its drivers' hands add, drawn from the race's seed.

A race is deterministic for its seed, which is right for reproducing one; an experiment must also sample the
conditions a race can start and run under. A :class:`ConditionSet` names the distributions; :meth:`ConditionSet.draw`
turns a seed into one race's :class:`RaceConditions`:

* **launch reaction**: each kart launches after a delay uniform in [0, ``start_spread``) (a driver's reaction to
  the lights);
* **grid**: side by side in the front row (the paper's), or ``staggered``: each kart ``stagger`` m behind the one
  before it in grid order (the order of :data:`sim_core.world.DEFAULT_START_LANES`: lane 2 on pole), as real
  karting grids stand; which kart starts in which lane is the race's (a tournament alternates them);
* **finish**: at the line on the last lap (the paper's), or ``equal_distance``: every kart after the race's laps
  from its own slot, so that no slot of a grid of several rows is a head start
  (:meth:`sim_core.world.World.finish_equal_distance`);
* **tyre wear at the start**, per kart, uniform in ``wear_range`` (the lateral grip falls with wear,
  :func:`sim_core.kart.lateral_limit`);
* **pace**, per kart, uniform in ``pace_range``: the kart drives as the reference kart at that pace
  (:meth:`sim_core.params.KartParams.paced`), times any handicap its agent string asks for (``NAME@PACE``);
* **driver imprecision**: seeded noise added to each kart's steer and throttle commands, an Ornstein-Uhlenbeck
  process (standard deviations ``steer_noise`` and ``throttle_noise`` of full scale, correlation time
  ``noise_time``): a hand's slow drift, not a per-step jitter the kart's inertia would average away.

The draws depend on the seed and the number of karts alone, never on the drivers: two pairings raced with the same
seeds meet the same conditions (a paired design). Named sets: :data:`CONDITION_SETS`.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass, field, replace
from typing import Any, Literal

import numpy as np
from numba import njit

from sim_core.params import DT, MIN_PACE, RuleParams
from sim_core.world import FINISH_RULES, FinishRule

GridLayout = Literal["side_by_side", "staggered"]
GRID_LAYOUTS: tuple[GridLayout, ...] = ("side_by_side", "staggered")
MAX_START_SPREAD = 2.0  # [s]
MAX_NOISE = 0.5  # of full scale: beyond it the commands are more noise than driver
# keep the random streams of each condition apart from each other and from any other use of the seed
LAUNCH_STREAM, WEAR_STREAM, NOISE_STREAM, PACE_STREAM = 0x57A27, 0x3EA2, 0x4015E, 0x9ACE
PAPER_WEAR = RuleParams().start_wear


@dataclass(frozen=True)
class RaceConditions:
    """One race's conditions, drawn (:meth:`ConditionSet.draw`): what a result records of how its race ran."""

    name: str  # the set drawn from
    launch_delays: tuple[float, ...]  # [s] per kart
    start_offsets: tuple[float, ...]  # [m] per kart, how far behind its grid row's line it stands
    start_wear: tuple[float, ...]  # [-] per kart
    steer_noise: float  # standard deviation, of full lock
    throttle_noise: float  # standard deviation, of full throttle
    noise_time: float  # [s] correlation time of the noise
    noise_seed: int  # seeds the noise's stream (:class:`Imprecision`)
    paces: tuple[float, ...] = ()  # [-] per kart (empty: every kart at the reference pace, 1)
    finish: FinishRule = "line"  # where each kart finishes (World.reset)

    def __post_init__(self) -> None:
        if not self.paces:
            object.__setattr__(self, "paces", (1.0,) * len(self.launch_delays))

    def launched(self, step: int) -> np.ndarray:
        """(K,) whether each kart's launch delay has passed at simulation step ``step`` (it drives from then on)."""
        return step * DT >= np.asarray(self.launch_delays)

    @property
    def imprecise(self) -> bool:
        """Whether the drivers' commands get noise."""
        return self.steer_noise > 0.0 or self.throttle_noise > 0.0

    def imprecision(self) -> Imprecision | None:
        """The noise source of this race's karts (``None`` without noise)."""
        if not self.imprecise:
            return None
        n = len(self.launch_delays)
        return Imprecision(n, self.steer_noise, self.throttle_noise, self.noise_time, self.noise_seed)

    def to_json(self) -> dict[str, Any]:
        """Every value, for a result's record."""
        return {**asdict(self), **{k: list(getattr(self, k)) for k in PER_KART}}

    @classmethod
    def from_json(cls, data: dict[str, Any]) -> RaceConditions:
        """Read back :meth:`to_json` (a record from before paces were drawn: every kart at pace 1)."""
        tuples = {k: tuple(float(v) for v in data.get(k, ())) for k in PER_KART}
        return cls(**{**data, **tuples})


PER_KART = ("launch_delays", "start_offsets", "start_wear", "paces")


@dataclass(frozen=True)
class ConditionSet:
    """The distributions a race's conditions are drawn from (see the module notes); ``name`` says which set."""

    name: str
    start_spread: float = 0.0  # [s] launch delays uniform in [0, start_spread)
    grid: GridLayout = "side_by_side"
    stagger: float = 2.0  # [m] between consecutive karts of a staggered grid
    wear_range: tuple[float, float] = (PAPER_WEAR, PAPER_WEAR)  # [-] start wear uniform in this range
    steer_noise: float = 0.0  # standard deviation, of full lock
    throttle_noise: float = 0.0  # standard deviation, of full throttle
    noise_time: float = 0.3  # [s] correlation time
    pace_range: tuple[float, float] = (1.0, 1.0)  # [-] each kart's pace uniform in this range
    finish: FinishRule = "line"  # where each kart finishes (World.reset)
    description: str = field(default="", compare=False)

    def __post_init__(self) -> None:
        problems = self.problems()
        if problems:
            raise ValueError(f"conditions {self.name!r}: " + "; ".join(problems))

    def problems(self) -> list[str]:
        """What is out of range (empty: nothing)."""
        found = []
        if not 0.0 <= self.start_spread <= MAX_START_SPREAD:
            found.append(f"start_spread must be in [0, {MAX_START_SPREAD}] s, got {self.start_spread}")
        if self.grid not in GRID_LAYOUTS:
            found.append(f"grid must be one of {list(GRID_LAYOUTS)}, got {self.grid!r}")
        if not 0.0 <= self.stagger <= 10.0:
            found.append(f"stagger must be in [0, 10] m, got {self.stagger}")
        low, high = self.wear_range
        if not 0.0 <= low <= high < 1.0:
            found.append(f"wear_range must be 0 <= low <= high < 1, got {self.wear_range}")
        for name in ("steer_noise", "throttle_noise"):
            if not 0.0 <= getattr(self, name) <= MAX_NOISE:
                found.append(f"{name} must be in [0, {MAX_NOISE}], got {getattr(self, name)}")
        pace_low, pace_high = self.pace_range
        if not MIN_PACE <= pace_low <= pace_high <= 1.0:
            found.append(f"pace_range must be {MIN_PACE:g} <= low <= high <= 1, got {list(self.pace_range)}")
        if not self.noise_time > 0.0:
            found.append(f"noise_time must be > 0 s, got {self.noise_time}")
        if self.finish not in FINISH_RULES:
            found.append(f"finish must be one of {list(FINISH_RULES)}, got {self.finish!r}")
        return found

    def draw(self, seed: int, n_karts: int, start_lanes: tuple[int, ...] | None = None) -> RaceConditions:
        """The conditions of race ``seed`` for ``n_karts`` karts; ``start_lanes`` orders a staggered grid (lane 2
        on pole, then 3, 1, 4; default: the karts' order)."""
        delays = (0.0,) * n_karts
        if self.start_spread > 0.0:
            launch = np.random.default_rng([abs(seed), LAUNCH_STREAM])
            delays = tuple(float(d) for d in launch.uniform(0.0, self.start_spread, n_karts))
        low, high = self.wear_range
        wear = (low,) * n_karts
        if high > low:
            wear = tuple(float(w) for w in np.random.default_rng([abs(seed), WEAR_STREAM]).uniform(low, high, n_karts))
        return RaceConditions(
            self.name,
            delays,
            self.start_offsets(n_karts, start_lanes),
            wear,
            self.steer_noise,
            self.throttle_noise,
            self.noise_time,
            int(np.random.SeedSequence([abs(seed), NOISE_STREAM]).generate_state(1)[0]),
            self._paces(seed, n_karts),
            self.finish,
        )

    def _paces(self, seed: int, n_karts: int) -> tuple[float, ...]:
        low, high = self.pace_range
        if high == low:
            return (low,) * n_karts
        return tuple(float(p) for p in np.random.default_rng([abs(seed), PACE_STREAM]).uniform(low, high, n_karts))

    def start_offsets(self, n_karts: int, start_lanes: tuple[int, ...] | None = None) -> tuple[float, ...]:
        """[m] how far behind its row's line each kart stands: 0 side by side; on a staggered grid ``stagger``
        per place in grid order (pole: the kart in lane 2, then 3, 1, 4; karts 5-8 likewise in the second row)."""
        if self.grid == "side_by_side":
            return (0.0,) * n_karts
        order = (2, 3, 1, 4)
        ranks = []
        for k in range(n_karts):
            lane = start_lanes[k] if start_lanes is not None else order[k % 4]
            ranks.append(order.index(lane) if lane in order else k % 4)
        return tuple(self.stagger * rank for rank in ranks)

    def to_json(self) -> dict[str, Any]:
        """Every parameter (a manifest's record of the set)."""
        return {**asdict(self), "wear_range": list(self.wear_range), "pace_range": list(self.pace_range)}


class Imprecision:
    """The drivers' hands: an Ornstein-Uhlenbeck noise per kart on steer and throttle, stepped once per
    simulation step (x <- a x + sqrt(1 - a^2) sigma e, a = exp(-dt / tau): stationary, standard deviation sigma)."""

    BLOCK = 256  # steps of normal draws taken at once (the same numbers, in the same order, as one draw a step)

    def __init__(self, n_karts: int, steer: float, throttle: float, time: float, seed: int) -> None:
        self.rng = np.random.default_rng(seed)
        self.decay = math.exp(-DT / time)
        self.sigma = np.array([steer, throttle])
        self.step_scale = math.sqrt(1.0 - self.decay**2) * self.sigma
        self.state = self.rng.standard_normal((n_karts, 2)) * self.sigma  # from the stationary distribution
        self._path = np.empty((0, n_karts, 2))  # the noise's states for the steps of the current block of draws
        self._next = 0

    def perturb(self, commands: np.ndarray, driving: np.ndarray) -> np.ndarray:
        """``commands`` (K, 2) with this step's noise added (clipped to [-1, 1]) where ``driving`` (K,) is true;
        the noise advances every step for every kart, so a kart's noise does not depend on the others'."""
        if self._next == len(self._path):
            draws = self.rng.standard_normal((self.BLOCK, *self.state.shape))
            self._path = _ou_path(self._path[-1] if len(self._path) else self.state, draws, self.decay, self.step_scale)
            self._next = 0
        self.state = self._path[self._next]
        self._next += 1
        noisy = np.minimum(np.maximum(commands + self.state, -1.0), 1.0)  # np.clip's values, without its overhead
        return np.where(driving[:, None], noisy, commands)


@njit(cache=True)
def _ou_path(start: np.ndarray, draws: np.ndarray, decay: float, step_scale: np.ndarray) -> np.ndarray:
    """The noise's next ``len(draws)`` states from ``start``, one step per draw (the same arithmetic, in the same
    order, as stepping it one step at a time: decay x + (sqrt(1 - decay^2) sigma) e)."""
    path = np.empty_like(draws)
    state = start.copy()
    for t in range(draws.shape[0]):
        for k in range(draws.shape[1]):
            for j in range(draws.shape[2]):
                state[k, j] = decay * state[k, j] + step_scale[j] * draws[t, k, j]
        path[t] = state
    return path


PAPER = ConditionSet(
    "paper",
    description="the original's experiment: every kart launches at once from a side-by-side grid, start wear "
    f"{PAPER_WEAR}, no imprecision",
)
VARIED = ConditionSet(
    "varied",
    start_spread=0.25,
    wear_range=(PAPER_WEAR - 0.05, PAPER_WEAR + 0.05),
    # the largest of the measured levels that keeps every agent's solo time within 0.5% of the paper's on both
    # tracks but one (docs/conditions.md; benchmarks/conditions.py)
    steer_noise=0.0075,
    throttle_noise=0.0125,
    noise_time=0.3,
    description="launch reactions within 0.25 s, start wear within +-0.05 of the paper's, and small seeded "
    "noise on every command (docs/conditions.md: the magnitude and its measurement)",
)
VARIED_PACE = replace(
    VARIED,
    name="varied-pace",
    pace_range=(0.98, 1.0),
    description="varied, and each kart's pace drawn per race within 2% of the kart's: agents of near pace, neither "
    "one always the faster",
)
VARIED_EQUAL_DISTANCE = replace(
    VARIED,
    name="varied-equal-distance",
    finish="equal_distance",
    description="varied, and every kart finishes after the same distance from its own grid slot: no row of a "
    "field's grid is a head start",
)
CONDITION_SETS: dict[str, ConditionSet] = {s.name: s for s in (PAPER, VARIED, VARIED_PACE, VARIED_EQUAL_DISTANCE)}
# the named sets, for typed request fields
ConditionName = Literal["paper", "varied", "varied-pace", "varied-equal-distance"]


def condition_set(name: str) -> ConditionSet:
    """The named set (``KeyError`` naming the known ones)."""
    try:
        return CONDITION_SETS[name]
    except KeyError:
        raise KeyError(f"unknown conditions {name!r}; known: {sorted(CONDITION_SETS)}") from None
