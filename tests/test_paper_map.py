"""docs/paper_map.md cannot rot: every ``file::name`` it names exists (found by parsing the file, so nothing is
imported), every path it names exists, and its equation numbers are those of the shipped paper source.

The last check needs the paper source, which lives beside the repository (``../shared/paper/``) and is not
part of a public clone; without it that test is skipped and says so.
"""

from __future__ import annotations

import ast
import re
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
PAPER_MAP = ROOT / "docs" / "paper_map.md"
PAPER_SOURCE = ROOT.parent / "shared" / "paper" / "hierarchical_racing.tex"

REFERENCE = re.compile(r"`([\w./-]+\.py)::([\w.]+)`")
PATH = re.compile(r"`([\w.-]+(?:/[\w.-]+)+\.(?:py|json|md))`")
EQUATION_ROW = re.compile(r"^\| \((\d+)\) \| `(eq:[\w:]+)` \|", re.MULTILINE)


def defined_names(body: list[ast.stmt]) -> dict[str, ast.stmt]:
    """Functions, classes and assigned names defined directly in ``body``."""
    names: dict[str, ast.stmt] = {}
    for node in body:
        if isinstance(node, ast.FunctionDef | ast.AsyncFunctionDef | ast.ClassDef):
            names[node.name] = node
        elif isinstance(node, ast.Assign):
            for target in node.targets:
                if isinstance(target, ast.Name):
                    names[target.id] = node
        elif isinstance(node, ast.AnnAssign) and isinstance(node.target, ast.Name):
            names[node.target.id] = node
    return names


def resolves(path: Path, dotted: str) -> bool:
    """Whether ``dotted`` (``name`` or ``Class.member``) is defined in the Python file ``path``."""
    body = ast.parse(path.read_text()).body
    for part in dotted.split("."):
        node = defined_names(body).get(part)
        if node is None:
            return False
        body = node.body if isinstance(node, ast.ClassDef) else []
    return True


def test_every_file_and_name_in_the_paper_map_exists() -> None:
    text = PAPER_MAP.read_text()
    references = REFERENCE.findall(text)
    assert len(references) > 40, "the map names too few functions: is the table format still `file::name`?"
    missing = []
    for file, name in sorted(set(references)):
        path = ROOT / file
        if not path.is_file():
            missing.append(f"{file} (no such file)")
        elif not resolves(path, name):
            missing.append(f"{file}::{name}")
    assert not missing, "docs/paper_map.md names what does not exist: " + ", ".join(missing)


def test_every_path_in_the_paper_map_exists() -> None:
    paths = set(PATH.findall(REFERENCE.sub("", PAPER_MAP.read_text())))
    missing = sorted(p for p in paths if not (ROOT / p).exists())
    assert not missing, f"docs/paper_map.md names missing files: {missing}"


def test_equations_are_listed_once_in_order() -> None:
    rows = EQUATION_ROW.findall(PAPER_MAP.read_text())
    numbers = [int(n) for n, _ in rows]
    assert numbers == list(range(1, len(numbers) + 1)), f"equation rows out of order or missing: {numbers}"
    assert len(numbers) >= 24


def numbered_equations(tex: str) -> list[str]:
    """Labels of the numbered equations in order: each ``\\begin{equation}`` (not ``equation*``) gets the next
    number, and its ``\\label`` names it (an unlabelled one still takes a number)."""
    labels = []
    for match in re.finditer(r"\\begin\{equation\}(.*?)\\end\{equation\}", tex, re.DOTALL):
        label = re.search(r"\\label\{([^}]*)\}", match.group(1))
        labels.append(label.group(1) if label else "")
    return labels


def test_equation_numbers_are_those_of_the_shipped_paper_source() -> None:
    if not PAPER_SOURCE.is_file():
        pytest.skip(
            f"needs the paper source {PAPER_SOURCE} (../shared/paper/ beside the repository, not in a public clone)"
        )
    tex = PAPER_SOURCE.read_text()
    tex = re.sub(r"(?<!\\)%.*", "", tex)  # comments hold no equations
    expected = {label: number for number, label in enumerate(numbered_equations(tex), start=1)}
    listed = {label: int(number) for number, label in EQUATION_ROW.findall(PAPER_MAP.read_text())}
    assert listed == {label: n for label, n in expected.items() if label}, (
        f"paper source: {expected}\ndocs/paper_map.md: {listed}"
    )
