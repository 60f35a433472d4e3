"""The warm-up loads every compiled kernel a race uses: after it, a race of every registered agent under the
``varied`` conditions (the drivers' noise, paces) adds no kernel signature. A kernel first compiled mid-race holds
the GIL for seconds: a live race's ticks stall and its karts' controllers are judged hung."""

from __future__ import annotations

import importlib
import pkgutil

from numba.core.registry import CPUDispatcher

import controllers
import sim_core
from controllers.race import RaceSpec, run_race
from controllers.registry import REGISTRY
from server.warmup import warm_planner, warm_tick_path
from sim_core.world import MAX_KARTS


def _signatures() -> dict[str, int]:
    """Each compiled function of the simulator's and controllers' modules: how many signatures it has loaded."""
    counts = {}
    for package in (sim_core, controllers):
        for module_info in pkgutil.walk_packages(package.__path__, f"{package.__name__}."):
            if module_info.name.startswith("controllers.rl"):
                continue  # imports torch: its kernels are warmed by the same driver calls
            module = importlib.import_module(module_info.name)
            for name, value in vars(module).items():
                if isinstance(value, CPUDispatcher) and value.__module__ == module.__name__:
                    counts[f"{module.__name__}.{name}"] = len(value.signatures)
    return counts


def test_after_the_warm_up_a_varied_race_compiles_nothing() -> None:
    warm_tick_path(REGISTRY.values())
    warm_planner()
    warmed = _signatures()
    names = sorted(REGISTRY)
    for first in range(0, len(names), MAX_KARTS):  # every registered agent in a field of up to 8 karts
        field = tuple(names[first : first + MAX_KARTS])
        run_race(RaceSpec("oval", field, seed=1, conditions="varied-pace", time_limit=3.0))
    grown = {k: (warmed.get(k, 0), n) for k, n in _signatures().items() if n > warmed.get(k, 0)}
    assert grown == {}, f"compiled after the warm-up (before, after): {grown}"
