"""How the command line prints: tables that never cut a value, at 80 columns as in a wide terminal or a pipe,
and ``--json`` output as one JSON object on the last line.

rich shortens cells that do not fit with an ellipsis by default, which cut the very names one types (``karting
tracks`` showed ``train-oval-l…``). Here identifier and number columns never wrap (rich narrows the other
columns first), every other column folds onto more lines instead of losing characters, and the tables are
drawn without vertical rules, one space between columns (the box draws it), so that wide ones fit 80 columns.
"""

from __future__ import annotations

import json
from collections.abc import Sequence
from typing import Annotated, Any

import typer
from rich import box
from rich.console import Console
from rich.table import Table
from rich.text import Text

# the --json flag every command that prints a result takes
JsonOption = Annotated[bool, typer.Option("--json", help="print one JSON object (the last line) instead of tables")]

console = Console()


def table(title: str, columns: Sequence[str], *, keys: Sequence[str] = (), numeric: Sequence[str] = ()) -> Table:
    """A table whose ``keys`` columns (names) and ``numeric`` ones (right-aligned) are never wrapped or cut, and
    whose other cells fold rather than end in an ellipsis. A column name may hold a line break."""
    shown = Table(
        title=title,
        title_justify="left",
        box=box.SIMPLE_HEAD,
        padding=0,
        collapse_padding=True,
        pad_edge=False,
    )
    for name in columns:
        shown.add_column(
            Text(name),
            justify="right" if name in numeric else "left",
            no_wrap=name in keys or name in numeric,
            overflow="fold",
        )
    return shown


def add_row(shown: Table, *cells: str) -> None:
    """A row of plain text (no rich markup: ``[m]`` in a unit or a name is shown as it is)."""
    shown.add_row(*(Text(cell) for cell in cells))


def print_json(data: Any) -> None:
    """``data`` as one line of JSON on standard output (the last line a command prints)."""
    print(json.dumps(data, separators=(",", ":")), flush=True)


def error(message: str) -> None:
    """An error line (on standard output with the rest, so tests and people see it together)."""
    console.print(f"[red]error:[/red] {message}", soft_wrap=True)
