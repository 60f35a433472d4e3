"""Race candidate RL weights on a track, one JSON line per race (run by ``run.sh`` on the lent machine).

    PYTHONPATH=$PWD python results/rl/session14/device/evaluate.py TASKS.jsonl WORKERS

Each line of TASKS is ``[label, agent, folder, opponent, track, seed]``: ``agent`` (a registered RL agent) drives
with the ``policy.npz`` in ``folder`` (the shipped weights when empty) against the registered ``opponent``; the
race is ``scripts/head_to_head.py``'s race number ``seed`` (kart 0 in lane 2 on even seeds).
"""

from __future__ import annotations

import json
import sys
from collections.abc import Callable
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

import controllers.rl.policy as policy_module
import controllers.rl.tracker as tracker_module

sys.path.insert(0, "scripts")
SHIPPED = policy_module.weights_folder


def race(task: tuple[str, str, str, str, str, int]) -> str:
    """One race of ``task`` as a JSON line (an ``error`` key instead of ``karts`` if it failed)."""
    label, agent, folder, opponent, track, seed = task

    def weights(name: str) -> Path:
        return Path(folder) if (name == agent and folder) else SHIPPED(name)

    tracker_module.weights_folder = weights  # type: ignore[assignment]
    import head_to_head

    line: dict[str, object] = {"label": label, "opponent": opponent, "track": track, "seed": seed}
    try:
        result = head_to_head.race_once(track, (agent, opponent), seed, seed).result
    except Exception as exc:  # a failed candidate is a result, not a crash of the batch
        line["error"] = repr(exc)
        return json.dumps(line)
    line["winner"] = result.winner
    line["karts"] = [
        {
            "finished": k.finished,
            "time": None if k.finish_time is None else round(k.finish_time, 2),
            "faults": k.collisions_at_fault,
            "illegal": k.illegal_lane_changes_per_step,
        }
        for k in result.karts
    ]
    return json.dumps(line)


def main(run_task: Callable[[tuple[str, str, str, str, str, int]], str] = race) -> None:
    """Run ``run_task`` on every task of the file in ``argv[1]`` with ``argv[2]`` processes, printing lines in
    task order."""
    with open(sys.argv[1]) as fh:
        tasks = [tuple(json.loads(line)) for line in fh if line.strip()]
    with ProcessPoolExecutor(int(sys.argv[2])) as pool:
        for line in pool.map(run_task, tasks):  # type: ignore[arg-type]
            print(line, flush=True)


if __name__ == "__main__":
    main()
