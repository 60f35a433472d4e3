"""Process trees for the crash tests: a process's descendants, and which of them still live."""

from __future__ import annotations

import time
from collections.abc import Iterable

import psutil


def descendants(pid: int) -> list[psutil.Process]:
    """Every process below ``pid`` now (children, their children, ...)."""
    return psutil.Process(pid).children(recursive=True)


def living(processes: Iterable[psutil.Process]) -> list[psutil.Process]:
    """Those of ``processes`` still running (a zombie, dead but not yet reaped, does not count)."""
    alive = []
    for process in processes:
        try:
            if process.is_running() and process.status() != psutil.STATUS_ZOMBIE:
                alive.append(process)
        except psutil.NoSuchProcess:
            pass
    return alive


def survivors_after(processes: Iterable[psutil.Process], seconds: float) -> list[psutil.Process]:
    """Those of ``processes`` still running ``seconds`` from now (returns early once none is)."""
    watched = list(processes)
    give_up = time.monotonic() + seconds
    while living(watched) and time.monotonic() < give_up:
        time.sleep(0.1)
    return living(watched)


def describe(processes: Iterable[psutil.Process]) -> list[str]:
    """``pid: command line`` of each (for assertion messages)."""
    shown = []
    for process in processes:
        try:
            shown.append(f"{process.pid}: {' '.join(process.cmdline())[:160]}")
        except psutil.Error:
            shown.append(f"{process.pid}: ?")
    return shown
