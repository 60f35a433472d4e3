"""Shared test configuration: deterministic hypothesis runs (no deadline: the first call of a compiled kernel
includes its compilation); tests marked ``slow`` first; and, for a parallel run (``-n``), numba's cache filled once
before the workers start."""

from __future__ import annotations

import sys

import pytest
from hypothesis import settings

import sim_core  # noqa: F401  (first: the numeric libraries' x86-64 level is set before they load)

settings.register_profile("project", deadline=None, derandomize=True, print_blob=True)
settings.load_profile("project")


def pytest_sessionstart(session: pytest.Session) -> None:
    """With xdist workers to come, compile the kernels once here (two processes, one per core) rather than in
    every worker and every server or pool process they start while the cache is still cold."""
    config = session.config
    if hasattr(config, "workerinput") or not getattr(config.option, "numprocesses", None):
        return
    from support.warm_kernels import warm

    seconds = warm()
    if seconds is not None:
        print(f"\nnumba kernels compiled into the cache in {seconds:.0f} s", file=sys.stderr)


def pytest_collection_modifyitems(items: list[pytest.Item]) -> None:
    """Tests marked ``slow`` first (the order is otherwise kept): a parallel run hands out whole modules in this
    order, so the longest ones start at once instead of leaving one worker busy at the end while the other idles."""
    items.sort(key=lambda item: item.get_closest_marker("slow") is None)
