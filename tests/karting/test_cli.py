"""The ``karting`` command line (karting/cli.py): tracks, import-track, race, and its errors (exit code 2)."""

from __future__ import annotations

import json
import math
import os
import subprocess
import sys
from pathlib import Path

from typer.testing import CliRunner

from karting.cli import app

ROOT = Path(__file__).resolve().parents[2]
runner = CliRunner()


def test_tracks_lists_the_builtin_tracks() -> None:
    done = runner.invoke(app, ["tracks"], env={"COLUMNS": "200"})
    assert done.exit_code == 0, done.output
    for name in ("oval", "complex", "train-oval-small", "train-oval-large"):
        assert name in done.output


def test_a_short_race_prints_the_referees_result(tmp_path: Path) -> None:
    replay = tmp_path / "race.json"
    args = ["race", "--track", "train-oval-small", "--karts", "lane-follower,lane-follower", "--laps", "1"]
    done = runner.invoke(app, [*args, "--replay", str(replay)], env={"COLUMNS": "200"})
    assert done.exit_code == 0, done.output
    assert "winner: kart" in done.output
    assert json.loads(replay.read_text())["track"] == "train-oval-small"


def test_unknown_controllers_and_tracks_exit_with_2() -> None:
    unknown = runner.invoke(app, ["race", "--karts", "lane-follower,nope"])
    assert unknown.exit_code == 2 and "nope" in unknown.output
    missing = runner.invoke(app, ["race", "--track", "no/such/track.json", "--karts", "lane-follower"])
    assert missing.exit_code == 2


def test_a_centre_line_csv_imports_as_a_track_file(tmp_path: Path) -> None:
    csv = tmp_path / "ring.csv"
    rows = [f"{60 * math.cos(a):.3f},{40 * math.sin(a):.3f},5,5" for a in (2 * math.pi * i / 80 for i in range(80))]
    csv.write_text("x_m,y_m,w_tr_right_m,w_tr_left_m\n" + "\n".join(rows) + "\n")
    out = tmp_path / "ring.json"
    done = runner.invoke(app, ["import-track", str(csv), "--out", str(out), "--laps", "2"])
    assert done.exit_code == 0, done.output
    assert json.loads(out.read_text())["name"] == "ring"
    broken = tmp_path / "broken.csv"
    broken.write_text("1,2,3\n")
    assert runner.invoke(app, ["import-track", str(broken), "--out", str(tmp_path / "x.json")]).exit_code == 2


def test_python_dash_m_karting_is_the_same_command_line() -> None:
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([str(ROOT), os.environ.get("PYTHONPATH", "")])}
    done = subprocess.run(
        [sys.executable, "-m", "karting", "--help"], capture_output=True, text=True, timeout=60, cwd=ROOT, env=env
    )
    assert done.returncode == 0, done.stderr
    for command in ("tracks", "import-track", "race", "serve"):
        assert command in done.stdout
