"""The ``karting`` command line (karting/cli.py): tracks, import-track, race, and its errors (exit code 2); read at
80 columns and through a pipe (no value cut short), and ``--json`` parsed."""

from __future__ import annotations

import json
import math
import os
import re
import subprocess
import sys
from pathlib import Path

from typer.testing import CliRunner

from karting.cli import app
from sim_core.track_io import builtin_track_names

ROOT = Path(__file__).resolve().parents[2]
runner = CliRunner()


NARROW = {"COLUMNS": "80"}
RACE = ["race", "--track", "train-oval-small", "--karts", "lane-follower,lane-follower", "--laps", "1"]


def _environment() -> dict[str, str]:
    """This process's environment with the repository importable and no terminal width set (a pipe)."""
    env = {k: v for k, v in os.environ.items() if k not in ("COLUMNS", "LINES")}
    env["PYTHONPATH"] = os.pathsep.join([str(ROOT), os.environ.get("PYTHONPATH", "")])
    return env


def _words(text: str) -> set[str]:
    return {word.strip("│┃,.;:()") for word in text.split()}


def test_tracks_shows_every_name_whole_at_80_columns() -> None:
    done = runner.invoke(app, ["tracks"], env=NARROW)
    assert done.exit_code == 0, done.output
    assert max(len(line) for line in done.output.splitlines()) <= 80
    assert "…" not in done.output
    for name in builtin_track_names():
        assert name in _words(done.output), name


def test_tracks_piped_shows_every_name_whole() -> None:
    done = subprocess.run(
        [sys.executable, "-m", "karting", "tracks"],
        capture_output=True,
        text=True,
        timeout=60,
        cwd=ROOT,
        env=_environment(),
    )
    assert done.returncode == 0, done.stderr
    assert "…" not in done.stdout and "\x1b[" not in done.stdout  # no ellipsis, no colour codes in a pipe
    assert max(len(line) for line in done.stdout.splitlines()) <= 80
    for name in builtin_track_names():
        assert name in _words(done.stdout), name


def test_tracks_json_lists_every_name_both_ways() -> None:
    done = runner.invoke(app, ["tracks", "--json"], env=NARROW)
    assert done.exit_code == 0, done.output
    listed = json.loads(done.output.strip().splitlines()[-1])
    names = [t["name"] for t in listed]
    assert names == [*builtin_track_names(), *(f"{n}-reversed" for n in builtin_track_names())]
    by_name = {t["name"]: t for t in listed}
    assert by_name["oval-reversed"]["description"] != by_name["oval"]["description"]


def test_a_short_race_prints_the_referees_result_at_80_columns(tmp_path: Path) -> None:
    replay = tmp_path / "race.json"
    done = runner.invoke(app, [*RACE, "--replay", str(replay)], env=NARROW)
    assert done.exit_code == 0, done.output
    assert max(len(line) for line in done.output.splitlines()) <= 80
    assert {"lane-follower 1", "lane-follower 2"} <= {line[6:21] for line in done.output.splitlines()}
    winner = re.search(r"^winner: kart (\d) \(lane-follower (\d)\)$", done.output, re.MULTILINE)
    assert winner is not None and winner.group(1) == winner.group(2) and winner.group(1) in ("1", "2")
    assert "kart 0" not in done.output  # karts are numbered from 1
    assert json.loads(replay.read_text())["track"] == "train-oval-small"


def test_race_json_is_the_apis_result_on_the_last_line() -> None:
    done = runner.invoke(app, [*RACE, "--seed", "3", "--start-lanes", "3,2", "--json"], env=NARROW)
    assert done.exit_code == 0, done.output
    result = json.loads(done.output.strip().splitlines()[-1])
    assert result["track"] == "train-oval-small" and result["status"] == "finished"
    assert result["seed"] == 3 and result["kart_preset"] == "paper" and result["start_lanes"] == [3, 2]
    karts = result["karts"]
    assert [k["index"] for k in karts] == [0, 1] and [k["name"] for k in karts] == [
        "lane-follower 1",
        "lane-follower 2",
    ]
    assert result["winner"] in (0, 1) and karts[result["winner"]]["winner"] and karts[result["winner"]]["position"] == 1
    for kart in karts:
        assert {"collisions_at_fault", "illegal_lane_changes", "safety_score", "delta_r", "delta_v", "passes"} <= set(
            kart
        )
        assert len(kart["lap_times"]) == kart["laps"] == 1
        assert math.isclose(sum(kart["lap_times"]), kart["finish_time"], abs_tol=0.002)
        assert kart["finish_time"] == round(kart["finish_time"], 3)  # to the millisecond, no float noise


def test_unknown_controllers_and_tracks_exit_with_2() -> None:
    unknown = runner.invoke(app, ["race", "--karts", "lane-follower,nope"])
    assert unknown.exit_code == 2 and "nope" in unknown.output
    missing = runner.invoke(app, ["race", "--track", "no/such/track.json", "--karts", "lane-follower"])
    assert missing.exit_code == 2
    bad = runner.invoke(app, ["race", "--karts", "lane-follower,fixed-lqng:line_margin_m=9"])
    assert bad.exit_code == 2 and "above its maximum" in bad.output


def test_a_kart_given_parameters_races_with_them() -> None:
    """``fixed-lqng@0.6`` drives its kart at a pace handicap of 0.6: a lap of it takes longer."""
    done = runner.invoke(
        app,
        [
            "race",
            "--track",
            "train-oval-small",
            "--karts",
            "fixed-lqng,fixed-lqng@0.6",
            "--laps",
            "1",
            "--json",
        ],
        env=NARROW,
    )
    assert done.exit_code == 0, done.output
    karts = json.loads(done.output.strip().splitlines()[-1])["karts"]
    assert karts[1]["finish_time"] > 1.2 * karts[0]["finish_time"]


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


def test_train_reward_weight_reaches_the_training_environment(monkeypatch, tmp_path: Path) -> None:  # type: ignore[no-untyped-def]
    import controllers.rl.train as training

    seen = {}

    def fake_training(env, ppo, folder, **_):  # type: ignore[no-untyped-def]
        seen["weights"] = env.weights
        return training.TrainResult(timesteps=0, wall_s=1.0, env_steps_per_s=0.0, out=folder)

    monkeypatch.setattr(training, "train", fake_training)
    args = ["train", "e2e", "--out", str(tmp_path), "--steps", "1", "--json"]
    done = runner.invoke(app, [*args, "--reward-weight", "target_lane=0", "--reward-weight", "player_hit=9"])
    assert done.exit_code == 0, done.output
    assert seen["weights"].target_lane == 0.0 and seen["weights"].player_hit == 9.0
    assert seen["weights"].speed == 1.0  # the rest as the spec
    bad = runner.invoke(app, [*args, "--reward-weight", "targetlane=0"], env=NARROW)
    assert bad.exit_code == 2 and "--reward-weight" in bad.output and "target_lane" in bad.output


def test_train_tracks_choose_the_training_set(monkeypatch, tmp_path: Path) -> None:  # type: ignore[no-untyped-def]
    import controllers.rl.train as training
    from controllers.rl.config import TRAINING_TRACKS

    seen = []

    def fake_training(env, ppo, folder, **_):  # type: ignore[no-untyped-def]
        seen.append(env.tracks)
        return training.TrainResult(timesteps=0, wall_s=1.0, env_steps_per_s=0.0, out=folder)

    monkeypatch.setattr(training, "train", fake_training)
    args = ["train", "mcts-rl", "--out", str(tmp_path), "--steps", "1", "--json"]
    assert runner.invoke(app, args).exit_code == 0
    chosen = runner.invoke(app, [*args, "--tracks", "train-narrow-hairpins, train-oval-small-reversed"])
    assert chosen.exit_code == 0, chosen.output
    assert seen == [TRAINING_TRACKS, ("train-narrow-hairpins", "train-oval-small-reversed")]
    bad = runner.invoke(app, [*args, "--tracks", "train-oval-small,no-such-track"], env=NARROW)
    assert bad.exit_code == 2 and "--tracks" in bad.output and "no-such-track" in bad.output
    assert len(seen) == 2  # nothing trained


def test_a_team_race_scores_the_teams_as_the_originals_team_races() -> None:
    karts = ["--karts", "lane-follower,fixed-lqng,lane-follower,fixed-lqng", "--teams", "blue,red,blue,red"]
    done = runner.invoke(app, [*RACE[:3], *karts, "--laps", "1", "--json"], env=NARROW)
    assert done.exit_code == 0, done.output
    result = json.loads(done.output.strip().splitlines()[-1])
    order = [k["index"] for k in sorted(result["karts"], key=lambda k: k["position"]) if k["finished"]]
    team_of = ("blue", "red", "blue", "red")
    expected = {"blue": 0.0, "red": 0.0}
    for place, index in enumerate(order):
        expected[team_of[index]] += (10.0, 7.5, 6.0, 4.0)[place]
    assert result["teams"]["points"] == expected and result["teams"]["winner"] == team_of[order[0]]
    shown = runner.invoke(app, [*RACE[:3], *karts, "--laps", "1"], env=NARROW)
    assert f"teams: {team_of[order[0]]} won" in shown.output
    refused = runner.invoke(app, [*RACE, "--teams", "blue"], env=NARROW)
    assert refused.exit_code == 2 and "need one team for each of the 2 karts" in refused.output


def test_solo_races_each_agent_alone_and_refuses_what_it_does_not_know() -> None:
    args = ["solo", "--agents", "lane-follower", "--tracks", "train-oval-small", "--workers", "1"]
    done = runner.invoke(app, [*args, "--json"])
    assert done.exit_code == 0, done.output
    (figures,) = json.loads(done.output.strip().splitlines()[-1])["solo"]
    assert (figures["agent"], figures["track"], figures["finished"]) == ("lane-follower", "train-oval-small", 1)
    assert figures["best_lap"] > 0 and figures["wall_hits"] == 0
    for bad, named in (("--agents", "nope"), ("--tracks", "nope"), ("--conditions", "nope")):
        refused = runner.invoke(app, [*args, bad, named], env=NARROW)
        assert refused.exit_code == 2 and "'nope'" in refused.output
