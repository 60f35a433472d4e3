"""The figure of a controller's own errors (exceptions, hangs, missed deadlines, failed plans) has one name
wherever a person reads it: "controller faults" (its JSON key is ``controller_faults``)."""

from __future__ import annotations

import re
from pathlib import Path

from web.frame import KartFrame, RaceFrame
from web.hud import hud_text, legend_text

ROOT = Path(__file__).resolve().parents[2]
OTHER_NAMES = re.compile(r"\b(ctrl|driver|kart)\.? faults\b", re.IGNORECASE)
READ_BY_PEOPLE = ("web", "server", "karting", "docs", "README.md")
SUFFIXES = {".py", ".js", ".html", ".md"}


def test_no_page_or_document_calls_controller_faults_anything_else() -> None:
    files = []
    for top in READ_BY_PEOPLE:
        path = ROOT / top
        files += [path] if path.is_file() else [p for p in path.rglob("*") if p.suffix in SUFFIXES]
    assert len(files) > 20  # the folders were found
    found = [f"{f.relative_to(ROOT)}: {m.group(0)}" for f in files for m in OTHER_NAMES.finditer(f.read_text())]
    assert found == []


def test_the_hud_and_the_race_page_say_controller_faults() -> None:
    kart = KartFrame(0, "A", "c", 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 1, 1, 0, 2, 0, 0, 0, False, None, 3)
    table = hud_text("oval", [("A", "c")], RaceFrame("r", "oval", 1.0, 50, 1, "running", (kart,), 0))
    head, _, row = table.splitlines()[-3:]
    assert head.split("|")[-2].strip() == "controller faults" and row.split("|")[-2].strip() == "3"
    assert legend_text().endswith("controller faults: errors, hangs, missed deadlines, failed plans")
    assert '"controller faults"].map' in (ROOT / "web" / "static" / "race.js").read_text()
