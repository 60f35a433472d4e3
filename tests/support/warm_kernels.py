"""Fill numba's on-disk cache before a parallel test run, so that test workers and the processes they start
(servers, planner workers, tournament pools) load the compiled kernels instead of each compiling them again.

``python tests/support/warm_kernels.py world`` steps a world and lets every registered controller decide once (the
server's warm-up path); ``... planner`` plans once with the MCTS planner. The two run side by side, one per core.
The cache folder is keyed on the sources (:mod:`sim_core._jit_cache`), so a marker file in it says the kernels of
these exact sources are compiled already.
"""

from __future__ import annotations

import os
import subprocess
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
PARTS = ("world", "planner")
MARKER = ".tests-warm"


def cache_dir() -> Path:
    """The numba cache folder of these sources (set by importing :mod:`sim_core`)."""
    import sim_core  # noqa: F401  (sets NUMBA_CACHE_DIR from the sources' hash unless it is set)

    return Path(os.environ["NUMBA_CACHE_DIR"])


def warm(timeout_s: float = 600.0) -> float | None:
    """Compile every kernel the tests use into the cache, unless these sources' cache is marked warm; returns the
    seconds it took, or None when it was warm already. A part that fails leaves the cache unmarked (the tests then
    compile what they need themselves) and its error on stderr."""
    folder = cache_dir()
    if (folder / MARKER).exists():
        return None
    started = time.monotonic()
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    parts = [subprocess.Popen([sys.executable, __file__, part], cwd=ROOT, env=env) for part in PARTS]
    codes = [part.wait(timeout_s) for part in parts]
    if all(code == 0 for code in codes):
        folder.mkdir(parents=True, exist_ok=True)
        (folder / MARKER).touch()
    return time.monotonic() - started


def _run_part(part: str) -> None:
    from controllers.registry import REGISTRY
    from server.warmup import warm_planner, warm_tick_path

    if part == "world":
        warm_tick_path(REGISTRY.values())
    else:
        warm_planner()


if __name__ == "__main__":
    _run_part(sys.argv[1])
