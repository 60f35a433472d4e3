"""Worker processes that die with the process that started them, even when it is killed (``SIGKILL``, a crash),
so a dead server or tournament leaves no orphans holding memory and CPU.

Call :func:`die_with_parent` first thing in every worker process (the tournament pool's workers here, the race
server's planner workers and controller hosts). Two ties, because each misses a case of the other:

* Linux's ``PR_SET_PDEATHSIG``: the kernel sends ``SIGKILL`` the moment the parent exits. It names the parent
  *thread* that forked the worker (so it also fires if only that thread ends) and, for a worker forked by a
  ``forkserver``, the fork server rather than the process that asked for the worker.
* A watchdog thread that waits on :func:`multiprocessing.parent_process`'s sentinel, which becomes ready when
  the process that created the ``Process`` object (the server, also through a fork server) is gone. A worker
  whose controller holds the GIL in a long compiled call still dies by the first tie.

The multiprocessing helpers (resource tracker, fork server) need no tie: each exits once every process holding
its pipe has ended.
"""

from __future__ import annotations

import contextlib
import ctypes
import ctypes.util
import multiprocessing
import os
import signal
import sys
import threading
from multiprocessing.connection import wait

PR_SET_PDEATHSIG = 1  # <linux/prctl.h>
ORPHAN_EXIT_CODE = 70  # the worker's exit status when its parent was found gone


def _set_parent_death_signal() -> bool:
    """Ask the kernel for ``SIGKILL`` when the parent exits; False where that is not available."""
    if not sys.platform.startswith("linux"):
        return False
    with contextlib.suppress(OSError, AttributeError):
        libc = ctypes.CDLL(ctypes.util.find_library("c") or "libc.so.6", use_errno=True)
        return int(libc.prctl(PR_SET_PDEATHSIG, int(signal.SIGKILL), 0, 0, 0)) == 0
    return False


def _watch(sentinel: int) -> None:
    wait([sentinel])
    os._exit(ORPHAN_EXIT_CODE)  # no clean-up: the parent that would want the results is gone


def die_with_parent() -> None:
    """Tie this worker process's life to its parent's (see the module docstring). Call it at the worker's start
    (a pool's ``initializer`` or a process's target); outside a multiprocessing child only the kernel tie is set."""
    parent_pid = os.getppid()
    _set_parent_death_signal()
    parent = multiprocessing.parent_process()
    if parent is not None:
        threading.Thread(target=_watch, args=(parent.sentinel,), name="die-with-parent", daemon=True).start()
    if os.getppid() != parent_pid:  # the parent died before the kernel tie was set
        os._exit(ORPHAN_EXIT_CODE)
