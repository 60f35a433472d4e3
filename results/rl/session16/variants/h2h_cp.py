"""``scripts/head_to_head.py`` with :mod:`candpatch`'s variants applied (see its docstring)."""

import sys

import candpatch  # noqa: F401  (applies the variants on import)

sys.path.insert(0, "scripts")
import head_to_head

head_to_head.app()
