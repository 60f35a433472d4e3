"""``karting train --config FILE.toml``: options from the file, flags over the file, unknown keys refused by name,
the default output folder, and the shipped example against the shipped weights' manifests (training itself is
replaced by a stub that records what it was asked to train)."""

from __future__ import annotations

import json
import re
import shlex
from pathlib import Path
from typing import Any

import pytest
from typer.testing import CliRunner

from controllers.rl.config import AGENT_KINDS, read_train_options
from karting.cli import app

ROOT = Path(__file__).resolve().parents[2]
SHIPPED = ROOT / "controllers" / "rl" / "configs" / "shipped.toml"
WEIGHTS = ROOT / "controllers" / "rl" / "weights"
KNOWN = ("steps", "seed", "gamma", "out", "normalise_reward", "reward_weight", "solo_spawns")
runner = CliRunner()


@pytest.fixture
def trained(monkeypatch: pytest.MonkeyPatch) -> list[dict[str, Any]]:
    """Every call of the training function, with its environment, PPO settings, folder and keywords."""
    import controllers.rl.train as training

    calls: list[dict[str, Any]] = []

    def stub(env: Any, ppo: Any, folder: Path, **kwargs: Any) -> Any:
        calls.append({"env": env, "ppo": ppo, "folder": folder, **kwargs})
        return training.TrainResult(timesteps=0, wall_s=1.0, env_steps_per_s=0.0, out=folder)

    monkeypatch.setattr(training, "train", stub)
    return calls


def write(tmp_path: Path, text: str) -> Path:
    path = tmp_path / "train.toml"
    path.write_text(text)
    return path


def train(*args: str) -> Any:
    return runner.invoke(app, ["train", *args, "--json"], env={"COLUMNS": "200"})


# --------------------------------------------------------------------------- the file's reader
def test_reader_takes_top_level_keys_then_the_agents_table(tmp_path: Path) -> None:
    text = 'steps = 10\nseed = 3\n[e2e]\nseed = 4\nreward-weight = ["target_lane=0"]\n[mcts-rl]\nseed = 5\n'
    path = write(tmp_path, text)
    assert read_train_options(path, "e2e", KNOWN) == {"steps": 10, "seed": 4, "reward_weight": ["target_lane=0"]}
    assert read_train_options(path, "fixed-rl", KNOWN) == {"steps": 10, "seed": 3}


def test_reader_reads_dashes_as_underscores(tmp_path: Path) -> None:
    path = write(tmp_path, "normalise-reward = true\nsolo_spawns = 0.5\n")
    assert read_train_options(path, "e2e", KNOWN) == {"normalise_reward": True, "solo_spawns": 0.5}


@pytest.mark.parametrize(
    ("text", "named"),
    [
        ("stepz = 10\n", "'stepz'"),
        ("[e2e]\nlearning-rate = 1e-3\n", "[e2e] 'learning-rate'"),
        ("[sac]\nsteps = 1\n", "'sac'"),
        ("solo-spawns = 0.1\nsolo_spawns = 0.2\n", "given twice"),
        ("steps = \n", "not TOML"),
    ],
)
def test_reader_names_the_problem(tmp_path: Path, text: str, named: str) -> None:
    with pytest.raises(ValueError, match=re.escape(named)):
        read_train_options(write(tmp_path, text), "e2e", KNOWN)


# --------------------------------------------------------------------------- the command
def test_the_file_sets_options_and_a_flag_overrides_it(tmp_path: Path, trained: list[dict[str, Any]]) -> None:
    path = write(tmp_path, f'out = "{tmp_path / "from-file"}"\nsteps = 1234\ngamma = 0.9\nsolo-spawns = 0.25\n')
    done = train("fixed-rl", "--config", str(path), "--steps", "7")
    assert done.exit_code == 0, done.output
    (call,) = trained
    assert call["ppo"].total_steps == 7  # the flag
    assert call["ppo"].gamma == 0.9 and call["env"].solo_probability == 0.25  # the file
    assert call["ppo"].seed == 0  # neither: the default
    assert call["folder"] == tmp_path / "from-file"


def test_a_flag_overrides_a_file_value_even_when_it_gives_the_default(tmp_path: Path, trained: list[Any]) -> None:
    path = write(tmp_path, f'out = "{tmp_path}"\nseed = 9\nnormalise-reward = true\n')
    done = train("e2e", "--config", str(path), "--seed", "0", "--no-normalise-reward")
    assert done.exit_code == 0, done.output
    assert trained[0]["ppo"].seed == 0 and trained[0]["ppo"].normalise_reward is False


@pytest.mark.parametrize(
    ("text", "named"),
    [
        ("stepz = 10\n", "stepz"),
        ("[e2e]\nlearning_rate = 1e-3\n", "learning_rate"),
        ("json = true\n", "json"),  # how a run prints is not a training option
        ('steps = "many"\n', "steps"),
        ("steps = true\n", "steps"),
        ("normalise-reward = 1\n", "normalise_reward"),
        ("solo-spawns = 2.0\n", "solo_spawns"),
        ('reward-weight = ["targetlane=0"]\n', "target_lane"),
    ],
)
def test_a_bad_key_or_value_is_a_usage_error_naming_it(
    tmp_path: Path, trained: list[Any], text: str, named: str
) -> None:
    done = train("e2e", "--config", str(write(tmp_path, text)), "--out", str(tmp_path))
    assert done.exit_code == 2, done.output
    assert named in done.output
    assert not trained


def test_the_default_output_folder_is_runs_rl_agent(trained: list[dict[str, Any]]) -> None:
    done = train("mcts-rl", "--steps", "1")
    assert done.exit_code == 0, done.output
    assert trained[0]["folder"] == Path("runs") / "rl" / "mcts-rl"
    assert json.loads(done.output.splitlines()[-1])["out"] == str(Path("runs") / "rl" / "mcts-rl")


# --------------------------------------------------------------------------- the shipped example
def last_stage_flags(agent: str) -> list[str]:
    """The options of the last training stage in ``agent``'s shipped manifest, without --out and
    --fine-tune-from (the folders of that run)."""
    command = json.loads((WEIGHTS / agent / "manifest.json").read_text())["stages"][-1]["command"]
    command = re.sub(r"\([^)]*\)", "", command).split(";")[0]  # the remarks in brackets and after a ;
    words = shlex.split(command)
    assert words[:3] == ["karting", "train", agent], command
    flags = []
    rest = iter(words[3:])
    for word in rest:
        if word in ("--out", "--fine-tune-from"):
            next(rest)
        else:
            flags.append(word)
    return flags


@pytest.mark.parametrize("agent", AGENT_KINDS)
def test_the_shipped_example_trains_as_the_manifests_last_stage(
    tmp_path: Path, trained: list[dict[str, Any]], agent: str
) -> None:
    flags = last_stage_flags(agent)
    assert "--gamma" in flags or agent == "fixed-rl"  # the parse found the options (fixed-rl kept the spec's)
    by_flags = train(agent, "--out", str(tmp_path), *flags)
    by_file = train(agent, "--out", str(tmp_path), "--config", str(SHIPPED))
    assert by_flags.exit_code == 0, by_flags.output
    assert by_file.exit_code == 0, by_file.output
    from_flags, from_file = trained
    assert from_file["env"] == from_flags["env"]
    assert from_file["ppo"] == from_flags["ppo"]
    assert from_file["ppo"] != type(from_file["ppo"])()  # the file changed the defaults


def test_last_stage_flags_reads_a_command_with_remarks() -> None:
    flags = last_stage_flags("e2e")
    assert flags[flags.index("--reward-weight") + 1] == "target_lane=0"
    assert "--fine-tune-from" not in flags and not any("(" in f or ";" in f for f in flags)
