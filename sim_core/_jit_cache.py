"""Point numba's on-disk cache at a folder named after a hash of every compiled module's source.

numba re-validates a cached kernel against its own file only: a kernel that calls a function from another
module (the tactical search calls the game's rules, the step calls the kart model) keeps running the old
callee after that module changes. Keying the whole cache on all sources makes any edit start a fresh cache.
Must run before numba is imported; an explicit ``NUMBA_CACHE_DIR`` wins.
"""

from __future__ import annotations

import hashlib
import os
import sys
from pathlib import Path

_PACKAGES = ("sim_core", "controllers")


def configure() -> None:
    """Set ``NUMBA_CACHE_DIR`` for this process (and the worker processes it starts) unless already set."""
    if "NUMBA_CACHE_DIR" in os.environ or "numba" in sys.modules:
        return
    root = Path(__file__).resolve().parent.parent
    digest = hashlib.sha1()
    for package in _PACKAGES:
        for path in sorted((root / package).rglob("*.py")):
            digest.update(path.relative_to(root).as_posix().encode())
            digest.update(path.read_bytes())
    base = Path(os.environ.get("XDG_CACHE_HOME", Path.home() / ".cache")) / "headtohead-karting" / "numba"
    os.environ["NUMBA_CACHE_DIR"] = str(base / digest.hexdigest()[:16])


configure()
