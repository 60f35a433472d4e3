"""Fill numba's on-disk cache before a parallel test run, so that test workers and the processes they start
(servers, planner workers, tournament pools) load the compiled kernels instead of each compiling them again.

``python tests/support/warm_kernels.py world`` steps a world and lets every registered controller decide once (the
server's warm-up path); ``... planner`` plans once with the MCTS planner. The two run side by side, one per core.
The cache folder is keyed on the sources' contents (:mod:`sim_core._jit_cache`), but numba files each kernel under
its source's folder path and checks the source's modification time: another checkout of the same sources (a CI
clone) finds nothing it can use there. So the marker file saying "compiled already" is named after the checkout's
path and its sources' times and sizes.
"""

from __future__ import annotations

import hashlib
import os
import subprocess
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
PARTS = ("world", "planner")
PACKAGES = ("sim_core", "controllers")


def cache_dir() -> Path:
    """The numba cache folder of these sources (set by importing :mod:`sim_core`)."""
    import sim_core  # noqa: F401  (sets NUMBA_CACHE_DIR from the sources' hash unless it is set)

    return Path(os.environ["NUMBA_CACHE_DIR"])


def marker_name() -> str:
    """The marker of this checkout's compiled kernels: its path and each source file's time and size (what numba
    checks before it loads a cached kernel)."""
    digest = hashlib.sha1(str(ROOT).encode())
    for package in PACKAGES:
        for path in sorted((ROOT / package).rglob("*.py")):
            stat = path.stat()
            digest.update(f"{path.relative_to(ROOT)}:{stat.st_mtime}:{stat.st_size}".encode())
    return f".tests-warm-{digest.hexdigest()[:16]}"


def warm(timeout_s: float = 600.0) -> float | None:
    """Compile every kernel the tests use into the cache, unless these sources' cache is marked warm; returns the
    seconds it took, or None when it was warm already. A part that fails leaves the cache unmarked (the tests then
    compile what they need themselves) and its error on stderr."""
    folder, marker = cache_dir(), marker_name()
    if (folder / marker).exists():
        return None
    started = time.monotonic()
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    parts = [subprocess.Popen([sys.executable, __file__, part], cwd=ROOT, env=env) for part in PARTS]
    codes = [part.wait(timeout_s) for part in parts]
    if all(code == 0 for code in codes):
        folder.mkdir(parents=True, exist_ok=True)
        (folder / marker).touch()
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
