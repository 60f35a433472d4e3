"""A random search over mcts-lqng's tactical and traffic settings for a win from lane 2 of `complex`.

Sessions 16-24 argued that `complex` is decided by the start lane: the inside of corner 1 is 8 m shorter and
mcts-lqng, about 1% faster alone, cannot pass an equally fast line follower afterwards. Each of those sessions
tried a few hand-made settings. This samples many at once: every public parameter of mcts-lqng that shapes its
plans, and every field of its LQ tracker that shapes how it drives near another kart (station keeping, passing,
alongside, yielding, blending, steering rate). The fields that set its pace alone (``speed_margin``,
``braking_use``, the LQ weights) stay as shipped, so a win would come from racing, not from a faster kart.

Phase 1 races each sampled setting once from lane 2 against fixed-lqng as registered (seed = 2 x index; the races
are deterministic per start lane up to the planner's seed). Phase 2 takes the settings that came closest and
races them from lane 3 and on the other tracks. Config 0 is mcts-lqng as registered. One JSON line per race,
flushed as it finishes (``--out``), so a run cut off keeps what it did.

    PYTHONPATH=$PWD .venv/bin/python results/issue11/session25/random_search.py --configs 600 --workers 16 \\
        --phase1-s 300 --deadline-s 450 --out results.jsonl
"""

from __future__ import annotations

import json
import random
import time
from concurrent.futures import FIRST_COMPLETED, Future, ProcessPoolExecutor, wait
from dataclasses import replace
from pathlib import Path
from typing import Any

import typer

from controllers.hierarchical import HierarchicalController
from controllers.lq.tracker import LQNGTracker
from controllers.race import RaceSpec, run_race
from controllers.registry import make_controller

KIDNEY = "results/issue11/kidney.json"
VALIDATION = (
    ("complex", 3),
    ("complex", 2),
    ("oval", 2),
    ("oval", 3),
    ("complex-reversed", 2),
    ("complex-reversed", 3),
    ("oval-reversed", 2),
    ("oval-reversed", 3),
    (KIDNEY, 2),
    (KIDNEY, 3),
)


def prior(rng: random.Random) -> dict[str, dict[str, Any]]:
    """A setting drawn from the search's prior: public parameters and tracker fields."""
    close = rng.random() < 0.7
    public = {
        "horizon": rng.choice([4, 6, 8, 8, 10, 12, 16]),
        "planner_rate_hz": rng.choice([0.5, 1.0, 1.0, 2.0, 4.0]),
        "racing_line_default": rng.random() < 0.7,
        "deviation_gain_s": round(rng.uniform(0.0, 0.3), 3),
        "hold_gain_s": round(rng.uniform(0.0, 0.3), 3),
        "pace_model": rng.random() < 0.6,
        "own_pace": round(rng.uniform(0.95, 1.15), 3),
        "close_following": close,
        "grip_steer": rng.choice([0.0, 0.0, round(rng.uniform(0.9, 1.0), 3)]),
    }
    tracker = {
        "traffic_lane_tolerance": round(rng.uniform(0.0, 1.5), 2),
        "alongside_distance": round(rng.uniform(0.0, 6.0), 2),
        "pass_distance": round(rng.uniform(0.0, 20.0), 1),
        "pass_clearance": round(rng.uniform(0.8, 2.5), 2),
        "pass_on_prediction": rng.random() < 0.7,
        "pass_speed_margin": round(rng.uniform(0.0, 1.0), 2),
        "follow_time": round(rng.uniform(0.0, 0.3), 3),
        "follow_band": round(rng.uniform(0.6, 1.6), 2),
        "follow_path_band": round(rng.uniform(0.0, 1.6), 2),
        "follow_predict_time": round(rng.uniform(0.0, 0.6), 2),
        "yield_speed_margin": round(rng.uniform(0.0, 3.0), 2),
        "alongside_clearance": round(rng.uniform(0.0, 2.0), 2),
        "steer_rate": rng.choice([0.0, round(rng.uniform(2.0, 10.0), 1)]),
        "lookahead_time": round(rng.uniform(0.35, 0.55), 3),
        "follow_distance": round(rng.uniform(1.8, 3.0), 2) if close else round(rng.uniform(2.0, 3.5), 2),
        "follow_distance_curve": round(rng.uniform(2.0, 3.5), 2) if close else 0.0,
    }
    return {"public": public, "tracker": tracker}


def without_pace(setting: dict[str, dict[str, Any]]) -> dict[str, dict[str, Any]]:
    """``setting`` with the entries that make a kart faster alone (``ablate.py``: ``grip_steer`` and
    ``lookahead_time``) as registered."""
    public = setting["public"] | {"grip_steer": 0.0}
    tracker = {key: value for key, value in setting["tracker"].items() if key != "lookahead_time"}
    return {"public": public, "tracker": tracker}


def mutate(parent: dict[str, dict[str, Any]], rng: random.Random, rate: float = 0.25) -> dict[str, dict[str, Any]]:
    """``parent`` with each entry redrawn from the prior with probability ``rate``."""
    fresh = prior(rng)
    return {
        part: {key: fresh[part][key] if rng.random() < rate else value for key, value in values.items()}
        for part, values in parent.items()
    }


def pace_of(setting: dict[str, dict[str, Any]]) -> dict[str, Any]:
    """The entries of ``setting`` that make a kart faster alone (found by ``ablate.py``), as fixed-lqng tracker
    fields: the matched control gives them to the opponent too."""
    fields = {"grip_steer": setting["public"].get("grip_steer", 0.0)}
    if "lookahead_time" in setting["tracker"]:
        fields["lookahead_time"] = setting["tracker"]["lookahead_time"]
    return fields


def race(
    index: int,
    setting: dict[str, dict[str, Any]],
    track: str,
    lane: int,
    seed: int,
    opponent: dict[str, Any] | None = None,
) -> dict[str, object]:
    """Setting ``index`` (``setting``; empty: as registered) starting in ``lane`` (fixed-lqng in the other of 2
    and 3, its tracker's fields changed by ``opponent``) on ``track``."""
    driver = make_controller("mcts-lqng", **setting["public"])
    assert isinstance(driver, HierarchicalController) and isinstance(driver.tracker, LQNGTracker)
    driver.tracker.params = replace(driver.tracker.params, **setting["tracker"])
    lanes = (lane, 5 - lane)
    spec = RaceSpec(track=track, controllers=("mcts-lqng", "fixed-lqng"), seed=seed, start_lanes=lanes)
    start = time.perf_counter()
    other = make_controller("fixed-lqng")
    assert isinstance(other, HierarchicalController) and isinstance(other.tracker, LQNGTracker)
    other.tracker.params = replace(other.tracker.params, **(opponent or {}))
    karts = run_race(spec, drivers=[driver, other]).result.karts
    times = [k.finish_time if k.finish_time is not None else float("inf") for k in karts]
    return {
        "config": index,
        "track": track,
        "lane": lane,
        "seed": seed,
        "won": times[0] < times[1],
        "margin": round(times[0] - times[1], 2) if all(t < float("inf") for t in times) else None,
        "times": [round(t, 2) if t < float("inf") else None for t in times],
        "passes": [k.passes for k in karts],
        "faults": [k.collisions_at_fault for k in karts],
        "illegal": [k.illegal_lane_changes for k in karts],
        "wall_s": round(time.perf_counter() - start, 1),
        "setting": setting,
        "opponent": opponent or {},
    }


def main(
    configs: int = 600,
    workers: int = 2,
    phase1_s: float = 300.0,
    deadline_s: float = 450.0,
    finalists: int = 12,
    random_share: float = 0.6,
    seed: int = 1000,
    matched: bool = False,
    pace: bool = True,
    out: Path = Path("random_search.jsonl"),
) -> None:
    """Phase 1 (lane 2 of `complex`, until ``phase1_s``: settings drawn from the prior for the first
    ``random_share`` of that time, then mutations of the 8 closest clean ones), then phase 2 (the ``finalists``
    closest, every validation race, until ``deadline_s``). ``matched``: fixed-lqng gets each setting's pace
    entries (:func:`pace_of`); ``--no-pace``: those entries stay as registered (:func:`without_pace`)."""
    began = time.monotonic()
    rows: list[dict[str, Any]] = []
    with out.open("w") as sink, ProcessPoolExecutor(workers) as pool:

        def collect(pending: set[Future[dict[str, object]]]) -> set[Future[dict[str, object]]]:
            done, pending = wait(pending, timeout=5.0, return_when=FIRST_COMPLETED)
            for future in done:
                row = future.result()
                rows.append(row)
                sink.write(json.dumps(row) + "\n")
                sink.flush()
            return pending

        def drain(pending: set[Future[dict[str, object]]], until: float) -> set[Future[dict[str, object]]]:
            while pending and time.monotonic() - began < until:
                pending = collect(pending)
            return pending

        settings: dict[int, dict[str, dict[str, Any]]] = {0: {"public": {}, "tracker": {}}}
        pending: set[Future[dict[str, object]]] = set()
        index = 0
        while time.monotonic() - began < phase1_s and index < configs:
            while index < configs and len(pending) < 2 * workers:
                rng = random.Random(seed + index)
                if index > 0:
                    clean = sorted(
                        (r for r in rows if r["margin"] is not None and r["faults"][0] == 0 and r["config"] > 0),
                        key=lambda r: r["margin"],
                    )
                    explore = time.monotonic() - began < random_share * phase1_s or len(clean) < 8
                    settings[index] = prior(rng) if explore else mutate(settings[rng.choice(clean[:8])["config"]], rng)
                    if not pace:
                        settings[index] = without_pace(settings[index])
                opponent = pace_of(settings[index]) if matched else None
                pending.add(pool.submit(race, index, settings[index], "complex", 2, 2 * (index % 25), opponent))
                index += 1
            pending = collect(pending)
        for future in pending:
            future.cancel()
        pending = drain({f for f in pending if not f.cancelled()}, phase1_s + 60.0)

        phase1 = [r for r in rows if r["track"] == "complex" and r["lane"] == 2 and r["margin"] is not None]
        clean = [r for r in phase1 if r["faults"][0] == 0]
        ranked = sorted(clean, key=lambda r: r["margin"])[:finalists]
        chosen = [0] + [r["config"] for r in ranked if r["config"] != 0]
        jobs = [
            (i, settings[i], t, lane, 1 if lane == 3 else 4, pace_of(settings[i]) if matched else None)
            for i in chosen
            for t, lane in VALIDATION
        ]
        pending = {pool.submit(race, *job) for job in jobs}
        pending = drain(pending, deadline_s)
        for future in pending:
            future.cancel()

    wins = [r for r in phase1 if r["won"]]
    summary = {
        "phase1_races": len(phase1),
        "phase1_wins": len(wins),
        "phase1_clean_wins": [r["config"] for r in wins if r["faults"][0] == 0],
        "best_clean_margins": [(r["config"], r["margin"]) for r in ranked],
        "baseline_margin": next((r["margin"] for r in phase1 if r["config"] == 0), None),
        "finalists": chosen,
        "elapsed_s": round(time.monotonic() - began, 1),
    }
    print(json.dumps(summary))


if __name__ == "__main__":
    typer.run(main)
