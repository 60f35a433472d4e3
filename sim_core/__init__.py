"""Simulation core: tracks, the kart model, the referee's rules and the batched world (numpy + numba only)."""

from sim_core import (
    _jit_cache,  # noqa: F401  (must configure numba's cache before numba is imported)
    _numeric_target,  # noqa: F401  (one x86-64 level for every library: before numpy is imported)
)
