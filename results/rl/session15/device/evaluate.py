"""Screen candidate RL weights (run by ``run.sh`` on the lent machine): session 14's head-to-head races, plus solo
races. One JSON line per task.

    PYTHONPATH=$PWD python results/rl/session15/device/evaluate.py TASKS.jsonl WORKERS

Each line of TASKS is ``[label, agent, folder, opponent, track, seed]`` as in
``results/rl/session14/device/evaluate.py``; the opponent ``solo`` races the agent alone
(``scripts/physics_audit.py``'s solo race: lap times, lateral acceleration, wall contact).
"""

from __future__ import annotations

import json
import sys
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parents[1] / "session14" / "device"))
sys.path.insert(0, "scripts")

import evaluate as session14  # noqa: E402

Task = tuple[str, str, str, str, str, int]


def race(task: Task) -> str:
    """One race of ``task`` as a JSON line (an ``error`` key if it failed)."""
    label, agent, folder, opponent, track, seed = task
    if opponent != "solo":
        return session14.race(task)

    def weights(name: str) -> Path:
        return Path(folder) if (name == agent and folder) else session14.SHIPPED(name)

    session14.tracker_module.weights_folder = weights  # type: ignore[assignment]
    import physics_audit

    line: dict[str, object] = {"label": label, "opponent": opponent, "track": track, "seed": seed}
    try:
        line["solo"] = physics_audit.solo_race(track, agent, seed, "paper")
    except Exception as exc:  # a failed candidate is a result, not a crash of the batch
        line["error"] = repr(exc)
    return json.dumps(line)


if __name__ == "__main__":
    session14.main(race)
