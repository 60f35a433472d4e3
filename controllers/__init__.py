"""Drivers: the controller Protocol and registry, planners, trackers and headless races."""

from sim_core import _jit_cache  # noqa: F401  (numba's cache and, by sim_core's import, the numeric x86-64 level)
