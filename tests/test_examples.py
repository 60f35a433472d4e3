"""The examples run as written: each numbered script in examples/ is run as a program (short races here) and
its output checked. The drive client (04) needs a live server: tests/server/test_server_api.py runs it against one."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
EXAMPLES = ROOT / "examples"
TESTED_ELSEWHERE = {"04_drive_client.py"}  # needs a live server: the server's API tests run it


def run_example(name: str, *args: str, cwd: Path = ROOT) -> str:
    """Run ``examples/<name>`` with this interpreter and this checkout first on the path; its stdout."""
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([str(ROOT), os.environ.get("PYTHONPATH", "")])}
    done = subprocess.run(
        [sys.executable, str(EXAMPLES / name), *args],
        capture_output=True,
        text=True,
        timeout=120,
        cwd=cwd,
        env=env,
    )
    assert done.returncode == 0, f"{name} failed:\n{done.stdout}\n{done.stderr}"
    return done.stdout


def test_every_example_is_numbered_and_tested() -> None:
    scripts = sorted(p.name for p in EXAMPLES.glob("*.py"))
    assert scripts, "no examples"
    here = Path(__file__).resolve()
    other_tests = "\n".join(p.read_text() for p in (ROOT / "tests").rglob("test_*.py") if p.resolve() != here)
    for name in scripts:
        assert name[:2].isdigit() and name[2] == "_", f"examples/{name} is not numbered (NN_name.py)"
        if name in TESTED_ELSEWHERE:
            assert f'"{name}"' in other_tests, f"examples/{name} is not run by any test"
        else:
            assert f'run_example("{name}"' in here.read_text(), f"examples/{name} has no test here"


def test_the_headless_race_runs_to_a_result() -> None:
    out = run_example("00_headless_race.py", "--track", "train-oval-small", "--laps", "1", "--seed", "1")
    assert "mcts-lqng" in out and "fixed-lqng" in out
    assert "winner: kart" in out


def test_the_batched_world_runs_every_race_to_the_end() -> None:
    out = run_example("01_batched_world.py", "--track", "train-oval-small", "--races", "8", "--karts", "3")
    assert "8 races x 3 karts on train-oval-small" in out
    assert "finishers: 24 of 24" in out


def test_the_custom_controller_is_registered_and_races() -> None:
    out = run_example("02_custom_controller.py", "--track", "train-oval-small", "--laps", "1")
    assert "ray-cruiser" in out and "lane-follower" in out
    assert "winner: " in out and "winner: nobody" not in out
    assert "DNF" not in out


def test_the_custom_track_is_written_imported_and_raced(tmp_path: Path) -> None:
    out = run_example("03_custom_track.py", "--out", str(tmp_path), "--laps", "1", cwd=tmp_path)
    assert (tmp_path / "bean.csv").exists() and (tmp_path / "bean.json").exists()
    assert "checkpoints" in out and "bean:" in out
    assert "DNF" not in out


def test_the_rl_environments_example_runs_every_env_and_the_shipped_policy() -> None:
    out = run_example("05_rl_env.py", "--decisions", "50")
    assert "gymnasium: observation (220,)" in out
    assert "shipped e2e policy" in out and "vector env: 16 races" in out and "pettingzoo: kart_0" in out


@pytest.mark.parametrize("name", sorted(p.name for p in EXAMPLES.glob("*.py")))
def test_every_example_explains_how_to_run_it(name: str) -> None:
    text = (EXAMPLES / name).read_text()
    assert f"examples/{name}" in text, f"examples/{name} does not show its own command line"
