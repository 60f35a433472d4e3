"""Imports flow one way: sim_core knows numpy and numba only; controllers know sim_core; torch only in
controllers/rl; nothing in sim_core or controllers knows HTTP, asyncio or viser."""

from __future__ import annotations

import ast
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
STDLIB = set(sys.stdlib_module_names)


def imported_roots(package: str) -> dict[str, set[str]]:
    found: dict[str, set[str]] = {}
    for path in (ROOT / package).rglob("*.py"):
        tree = ast.parse(path.read_text())
        for node in ast.walk(tree):
            if isinstance(node, ast.Import):
                names = [a.name for a in node.names]
            elif isinstance(node, ast.ImportFrom) and node.level == 0 and node.module:
                names = [node.module]
            else:
                continue
            for name in names:
                found.setdefault(name.split(".")[0], set()).add(str(path.relative_to(ROOT)))
    return found


def test_sim_core_imports_only_numpy_and_numba() -> None:
    roots = imported_roots("sim_core")
    allowed = {"numpy", "numba", "sim_core", "__future__"}
    # the command line is the one edge inside sim_core: it may use typer/rich, run controllers and start the server
    cli_only = {"typer", "rich", "controllers", "server", "uvicorn"}
    for name, files in roots.items():
        if name in STDLIB or name in allowed:
            continue
        assert name in cli_only and files == {"sim_core/cli.py"}, f"sim_core imports {name} in {sorted(files)}"
    assert "asyncio" not in roots


def test_controllers_know_no_server_and_torch_only_in_rl() -> None:
    roots = imported_roots("controllers")
    for banned in ("fastapi", "uvicorn", "viser", "asyncio", "server", "web", "starlette"):
        assert banned not in roots, f"controllers import {banned}: {roots[banned]}"
    for path in roots.get("torch", set()):
        assert path.startswith("controllers/rl/"), f"torch imported outside controllers/rl: {path}"
