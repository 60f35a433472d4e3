"""``scripts/head_to_head.py`` with the modules named in ``PATCHES`` (comma separated) imported first."""

import importlib
import os
import sys

for name in filter(None, os.environ.get("PATCHES", "").split(",")):
    importlib.import_module(name)
sys.path.insert(0, "scripts")
import head_to_head  # noqa: E402

head_to_head.app()
