"""Ship a trained RL agent: export ``policy.npz`` from a ``karting train`` folder into
``controllers/rl/weights/AGENT/`` with the normalisation statistics, the log, the curves and a manifest.

From the repo root::

    .venv/bin/python scripts/ship_rl_weights.py e2e runs/rl/e2e --seed 0 --wall-s 420 --commit abc1234 \
        --command "karting train e2e --steps 3000000" --note "interim weights"

A model trained in stages (e.g. from scratch on one machine, then ``--fine-tune-from`` on another) lists each
stage with ``--stage '{"command": ..., "commit": ..., "machine": ..., "wall_s": ..., "steps": ...}'`` (repeat
it, in order); ``--command``, ``--commit`` and ``--wall-s`` then describe the whole.
"""

from __future__ import annotations

import argparse
import csv
import json
import os
import platform
import shutil
from pathlib import Path

from controllers.rl.curves import plot_curves
from controllers.rl.policy import export_policy, weights_folder


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("agent")
    parser.add_argument(
        "folder", type=Path, help="the karting train output folder, or one of its checkpoints (with policy.npz)"
    )
    parser.add_argument("--log", type=Path, help="the training log (default FOLDER/training_log.csv)")
    parser.add_argument("--command", required=True)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--wall-s", type=float, required=True)
    parser.add_argument("--commit", required=True, help="git commit the training ran on")
    parser.add_argument("--note", default="")
    parser.add_argument("--machine", default="", help="where it trained (default: this machine)")
    parser.add_argument("--stage", action="append", default=[], help="one training stage as JSON (repeatable)")
    args = parser.parse_args()
    out = weights_folder(args.agent)
    out.mkdir(parents=True, exist_ok=True)
    log = args.log or args.folder / "training_log.csv"
    if (args.folder / "model.zip").exists():
        export_policy(args.folder, out)
    else:  # a checkpoint exported where it was trained (its model.zip left behind)
        shutil.copy(args.folder / "policy.npz", out / "policy.npz")
    shutil.copy(args.folder / "vecnormalize.pkl", out / "vecnormalize.pkl")
    with log.open() as fh:
        rows = list(csv.DictReader(fh))
    if args.folder.name.startswith("step_"):  # the log up to the checkpoint
        rows = [r for r in rows if int(r["timesteps"]) <= int(args.folder.name.removeprefix("step_"))]
    with (out / "training_log.csv").open("w", newline="") as fh:
        writer = csv.DictWriter(fh, fieldnames=list(rows[0]))
        writer.writeheader()
        writer.writerows(rows)
    plot_curves(out / "training_log.csv", out / "curves.png", title=f"{args.agent}: PPO self-play")
    rewards = [(int(r["timesteps"]), float(r["ep_rew_mean"])) for r in rows if r["ep_rew_mean"]]
    manifest = {
        "agent": args.agent,
        "command": args.command,
        "seed": args.seed,
        "steps": int(rows[-1]["timesteps"]),
        "wall_s": round(args.wall_s, 1),
        "machine": args.machine
        or f"{platform.node()} {platform.machine()} {os.cpu_count()} cores, {platform.python_version()}",
        "stages": [json.loads(stage) for stage in args.stage],
        "git_commit": args.commit,
        "files": {
            "policy.npz": "the actor (3x128 tanh + action head), observation mean/variance/clip, log std: inference",
            "vecnormalize.pkl": "Stable-Baselines3 VecNormalize statistics (the same mean/variance)",
            "training_log.csv": "one row per PPO update",
            "curves.png": "reward, episode length, value loss",
        },
        "first_ep_rew_mean": rewards[0] if rewards else None,
        "last_ep_rew_mean": rewards[-1] if rewards else None,
        "note": args.note,
    }
    (out / "manifest.json").write_text(json.dumps(manifest, indent=2) + "\n")
    print(out)


if __name__ == "__main__":
    main()
