"""Train RL variants side by side and race each one: the experiment behind the shipped RL weights.

Each variant is a ``karting train`` run (its own process, one torch thread) into ``OUT/NAME``; then each
trained policy races ``fixed-lqng`` on the evaluation tracks (seeded, start lanes alternating), acting with the
Gaussian's mean and with samples from it (stall recovery on, as the registered agents). One JSON object per
variant goes to ``OUT/sweep.json`` and the last line of stdout.

    .venv/bin/python scripts/rl_sweep.py --out runs/rl_sweep --variants scripts/rl_variants/sweep1.json --steps 3000000

A variant file is a JSON list of ``{"name": ..., "agent": "fixed-rl", "args": ["--normalise-reward", ...]}``.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import time
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

import numpy as np

from controllers.rl.policy import export_policy

ROOT = Path(__file__).resolve().parents[1]


def train_all(variants: list[dict], out: Path, steps: int, races: int) -> dict[str, float]:
    """Run every variant's training at once; wall seconds per variant."""
    procs = {}
    start = time.perf_counter()
    for v in variants:
        folder = out / v["name"]
        folder.mkdir(parents=True, exist_ok=True)
        cmd = [sys.executable, "-m", "karting", "train", v["agent"], "--out", str(folder), "--steps", str(steps)]
        cmd += ["--races", str(races), "--checkpoint-steps", str(10 * steps), *v.get("args", [])]
        log = (folder / "train_stdout.txt").open("w")
        procs[v["name"]] = (subprocess.Popen(cmd, stdout=log, stderr=subprocess.STDOUT, cwd=ROOT), log)
    walls = {}
    for name, (proc, log) in procs.items():
        proc.wait()
        log.close()
        walls[name] = round(time.perf_counter() - start, 1)
        if proc.returncode:
            print(f"{name}: training failed ({proc.returncode})", flush=True)
    return walls


def _race(args: tuple[str, str, str, str, bool, int]) -> dict:
    """One race of a trained policy against ``opponent`` (runs in a worker process)."""
    from controllers.base import Controller
    from controllers.fixed_line import FixedLinePlanner
    from controllers.hierarchical import HierarchicalController
    from controllers.race import RaceSpec, run_race
    from controllers.registry import REGISTRY, ControllerSpec, register
    from controllers.rl.agents import RL_RATE_HZ, E2EController
    from controllers.rl.config import agent_kind
    from controllers.rl.filters import RecoverFromStall
    from controllers.rl.tracker import RLTracker

    folder, agent, track, opponent, deterministic, seed = args
    name = f"sweep-{abs(hash((folder, deterministic))) % 10**8}"
    if name not in REGISTRY:
        kind = agent_kind(agent)

        def factory() -> Controller:
            if kind == "e2e":
                return E2EController(folder, deterministic, filters=(RecoverFromStall(),))
            tracker = RLTracker(kind, folder, deterministic, filters=(RecoverFromStall(),))
            return HierarchicalController(kind, FixedLinePlanner(), tracker, rate_hz=RL_RATE_HZ)

        register(ControllerSpec(name, "sweep variant", factory))
    lanes = (2, 3) if seed % 2 == 0 else (3, 2)
    outcome = run_race(RaceSpec(track=track, controllers=(name, opponent), seed=seed, start_lanes=lanes))
    me = outcome.result.karts[0]
    return {
        "track": track,
        "deterministic": deterministic,
        "seed": seed,
        "finished": bool(me.finished),
        "time": me.finish_time if me.finished else None,
        "checkpoints": int(me.checkpoints_passed),
        "wall_hits": int(me.wall_hits),
        "faults": int(me.collisions_at_fault),
        "illegal": int(me.illegal_lane_changes),
        "won": outcome.result.winner == 0,
    }


def evaluate(
    variants: list[dict],
    out: Path,
    tracks: list[str],
    races: int,
    workers: int,
    modes: tuple[bool, ...] = (True, False),
) -> dict[str, dict]:
    """Race every trained variant; a summary per variant and mode."""
    jobs = []
    for v in variants:
        folder = str(out / v["name"])
        if not (Path(folder) / "model.zip").exists():
            continue
        export_policy(folder)  # before the workers start: they only read it
        for track in tracks:
            for det in modes:
                for seed in range(races):
                    jobs.append((v["name"], (folder, v["agent"], track, "fixed-lqng", det, seed)))
    with ProcessPoolExecutor(workers) as pool:
        results = list(pool.map(_race, [j[1] for j in jobs]))
    summary: dict[str, dict] = {}
    for (name, _job), res in zip(jobs, results):
        key = f"{res['track']}/{'mean' if res['deterministic'] else 'sample'}"
        cell = summary.setdefault(name, {}).setdefault(key, [])
        cell.append(res)
    for cells in summary.values():
        for key, rows in cells.items():
            times = [r["time"] for r in rows if r["time"] is not None]
            cells[key] = {
                "finished": f"{sum(r['finished'] for r in rows)}/{len(rows)}",
                "wins": sum(r["won"] for r in rows),
                "mean_finish_s": round(float(np.mean(times)), 2) if times else None,
                "checkpoints": [r["checkpoints"] for r in rows],
                "faults_per_race": round(float(np.mean([r["faults"] for r in rows])), 2),
                "illegal_per_race": round(float(np.mean([r["illegal"] for r in rows])), 2),
                "wall_hits_per_race": round(float(np.mean([r["wall_hits"] for r in rows])), 2),
            }
    return summary


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--out", type=Path, required=True)
    parser.add_argument("--variants", type=Path, required=True)
    parser.add_argument("--steps", type=int, default=3_000_000)
    parser.add_argument("--races", type=int, default=128, help="training races per variant")
    parser.add_argument("--eval-tracks", default="oval,complex")
    parser.add_argument("--eval-races", type=int, default=2)
    parser.add_argument("--workers", type=int, default=os.cpu_count() or 2)
    parser.add_argument("--skip-training", action="store_true")
    parser.add_argument("--modes", default="mean,sample", help="mean (most likely decision), sample, or both")
    args = parser.parse_args()
    variants = json.loads(args.variants.read_text())
    args.out.mkdir(parents=True, exist_ok=True)
    walls = {} if args.skip_training else train_all(variants, args.out, args.steps, args.races)
    modes = tuple(m == "mean" for m in args.modes.split(","))
    summary = evaluate(variants, args.out, args.eval_tracks.split(","), args.eval_races, args.workers, modes)
    for v in variants:
        log = args.out / v["name"] / "training_log.csv"
        last = log.read_text().strip().splitlines()[-1] if log.exists() else ""
        summary.setdefault(v["name"], {})["train"] = {"wall_s": walls.get(v["name"]), "last_log_row": last}
    (args.out / "sweep.json").write_text(json.dumps(summary, indent=1))
    print(json.dumps(summary))


if __name__ == "__main__":
    main()
