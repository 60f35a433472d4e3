"""Imports flow one way, with no exceptions:

    karting (the command line: composes everything; nothing imports it)
      -> server -> web, arena -> controllers -> sim_core

sim_core knows the standard library, numpy and numba only; controllers know sim_core (torch only in
controllers/rl) and nothing of HTTP, asyncio, viser, the server or the command line; web knows sim_core and
its HTTP/3D libraries but never the server or the drivers (the server hands it what it draws); arena (many races:
tournaments, statistics, reports) knows sim_core and controllers and nothing of HTTP, asyncio or the server,
and neither sim_core nor controllers know arena.
"""

from __future__ import annotations

import ast
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
STDLIB = set(sys.stdlib_module_names)
PACKAGES = ("sim_core", "controllers", "arena", "server", "web", "karting")
# everything in the repository that could import the command line, besides the tests (which test it)
NOT_KARTING = ("sim_core", "controllers", "arena", "server", "web", "benchmarks", "scripts", "examples")


def imported_roots(folder: str) -> dict[str, set[str]]:
    """Top-level names imported anywhere under ``folder`` (at any depth, lazy imports included) -> files."""
    found: dict[str, set[str]] = {}
    for path in (ROOT / folder).rglob("*.py"):
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


def test_every_package_is_scanned() -> None:
    for package in PACKAGES:
        assert (ROOT / package / "__init__.py").exists(), f"{package} is not a package"
        assert imported_roots(package), f"no imports found in {package}"


def test_sim_core_imports_only_the_standard_library_numpy_and_numba() -> None:
    roots = imported_roots("sim_core")
    allowed = {"numpy", "numba", "sim_core"}
    for name, files in roots.items():
        assert name in STDLIB or name in allowed, f"sim_core imports {name} in {sorted(files)}"
    assert "asyncio" not in roots, f"sim_core imports asyncio in {sorted(roots['asyncio'])}"


def test_controllers_know_no_server_web_or_command_line_and_torch_only_in_rl() -> None:
    roots = imported_roots("controllers")
    for banned in ("fastapi", "uvicorn", "viser", "asyncio", "starlette", "server", "web", "karting", "arena"):
        assert banned not in roots, f"controllers import {banned}: {sorted(roots[banned])}"
    for path in roots.get("torch", set()):
        assert path.startswith("controllers/rl/"), f"torch imported outside controllers/rl: {path}"


def test_arena_knows_sim_core_and_controllers_but_no_server_http_or_asyncio() -> None:
    roots = imported_roots("arena")
    for banned in ("fastapi", "uvicorn", "viser", "asyncio", "starlette", "httpx", "server", "web", "karting"):
        assert banned not in roots, f"arena imports {banned}: {sorted(roots[banned])}"


def test_sim_core_never_imports_arena() -> None:
    roots = imported_roots("sim_core")
    assert "arena" not in roots, f"sim_core imports arena: {sorted(roots['arena'])}"


def test_web_never_imports_the_server_or_the_drivers() -> None:
    roots = imported_roots("web")
    for banned in ("server", "controllers", "karting"):
        assert banned not in roots, f"web imports {banned}: {sorted(roots[banned])}"


@pytest.mark.parametrize("folder", NOT_KARTING)
def test_nothing_imports_the_command_line(folder: str) -> None:
    if not (ROOT / folder).is_dir():
        pytest.skip(f"no {folder}/ in this checkout")
    roots = imported_roots(folder)
    assert "karting" not in roots, f"{folder} imports karting: {sorted(roots['karting'])}"
