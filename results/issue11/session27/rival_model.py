"""How well does the rollout check's model of the other kart predict it? (session 27)

The check (controllers/rollout_check.py) races the other kart as an LQ tracker on the lanes the MCTS plan predicts
for it, with fixed-lqng's settings (``RIVAL_TRACKING``). This script measures that model against each registered
opponent: mcts-lqng as registered races OPPONENT on TRACK from both start lanes; every second at which the check
would run (the other kart within 25 m ahead or 3 m behind), the two karts are placed in a private world at what
mcts-lqng saw, mcts-lqng's tracker drives the plan it had then, and the other kart is driven by each candidate
model for 2 s (on the plan it was driving then, or with ``--plan fresh`` the one it had just computed from that
moment: the rollout check races the fresh one). Reported: the distance [m] between where each model puts the other
kart and where it really was, 0.5, 1 and 2 s on (mean and 90th percentile over the samples), next to a
constant-speed, constant-offset guess.

    PYTHONPATH=$PWD .venv/bin/python results/issue11/session27/rival_model.py --track complex \
        --opponents fixed-lqng,e2e,fixed-rl,mcts-rl,mcts-lqng > results/issue11/session27/rival_model_complex.txt
"""

from __future__ import annotations

import argparse
import json
from dataclasses import dataclass, replace

import numpy as np

from controllers.base import RaceContext
from controllers.hierarchical import HierarchicalController
from controllers.lq.tracker import CLOSE_FOLLOWING_TRACKING, FIXED_LINE_TRACKING, MCTS_TRACKING, LQNGParams, LQNGTracker
from controllers.plan import Plan
from controllers.race import RaceSpec, run_race
from sim_core.observation import Observation, observe, place_view
from sim_core.params import SimParams
from sim_core.world import World

MODELS: dict[str, LQNGParams] = {
    "fixed-lqng's tracker (RIVAL_TRACKING)": FIXED_LINE_TRACKING,
    "generic LQNGParams()": LQNGParams(),
    "mcts-lqng's tracker": CLOSE_FOLLOWING_TRACKING,
    "mcts-lqng's tracker, linear spacing": MCTS_TRACKING,
}
HORIZONS = (25, 50, 100)  # steps of 0.02 s
REACH, BEHIND = 25.0, 3.0


@dataclass
class Sample:
    step: int
    observation: Observation
    plan: Plan


def race(
    track: str, opponent: str, lanes: tuple[int, int], seed: int, fresh: bool
) -> tuple[list[Sample], np.ndarray, World]:
    """mcts-lqng against ``opponent``: the samples (each second) and the other kart's (x, y) at every step. Each
    sample's plan is the one mcts-lqng drives then (``fresh`` False: computed a second before), or the one it has
    just computed from that moment (True: what the rollout check races)."""
    samples: list[Sample] = []
    positions: list[np.ndarray] = []
    worlds: list[World] = []

    def hook(world: World, drivers: object, step: int) -> None:
        if not worlds:
            worlds.append(world)
        positions.append(world.positions[0, 1].copy())
        driver = drivers[0]  # type: ignore[index]
        assert isinstance(driver, HierarchicalController)
        plan = driver._pending.plan if fresh and driver._pending is not None else driver.active_plan
        if step % 50 == 0 and plan is not None:
            samples.append(Sample(step, observe(world, 0)[0], plan))

    spec = RaceSpec(track, ("mcts-lqng", opponent), seed=seed, start_lanes=lanes)
    run_race(spec, on_step=hook)
    return samples, np.array(positions), worlds[0]


def predict(world: World, sample: Sample, model: LQNGParams, context: RaceContext) -> np.ndarray | None:
    """The other kart's (x, y) after each of ``HORIZONS`` steps with ``model`` driving it; None: out of reach."""
    observation = sample.observation
    rival = next(iter(observation.others()), None)
    if rival is None:  # it has finished
        return None
    gap = world.track.gap(observation.me.progress, rival.progress)
    if not -BEHIND < gap < REACH:
        return None
    private = World(world.track, 1, 2, SimParams(kart=context.kart), sensors=False)
    trackers = (LQNGTracker(CLOSE_FOLLOWING_TRACKING), LQNGTracker(model))
    for slot, tracker in enumerate(trackers):
        tracker.reset(replace(context, ego=slot))
    plan = replace(
        sample.plan,
        ego=0,
        waypoints={0: sample.plan.waypoints.get(observation.ego, ()), 1: sample.plan.waypoints.get(rival.index, ())},
    )
    for slot, view in enumerate((observation.me, rival)):
        place_view(private, 0, slot, view)
    views = observe(private, 0)
    for slot, tracker in enumerate(trackers):
        place_view(private, 0, slot, views[slot].me, tracker.start_steering(views[slot], plan))
    out = []
    actions = np.zeros((1, 2, 2))
    for step in range(1, max(HORIZONS) + 1):
        views = observe(private, 0)
        for slot, tracker in enumerate(trackers):
            action = tracker.act(views[slot], plan)
            actions[0, slot] = (action.steer, action.throttle)
        private.step(actions)
        if step in HORIZONS:
            out.append(private.positions[0, 1].copy())
    return np.array(out)


def constant_guess(world: World, sample: Sample) -> np.ndarray:
    """The other kart carried on along the centre line at its speed, at its lateral offset."""
    rival = next(iter(sample.observation.others()))
    out = []
    for h in HORIZONS:
        point, tangent = world.track.point_at(rival.progress + rival.speed * h * 0.02)
        out.append(point + rival.lateral * np.array([-tangent[1], tangent[0]]))
    return np.array(out)


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--track", default="complex")
    ap.add_argument("--opponents", default="fixed-lqng,e2e,fixed-rl,mcts-rl,mcts-lqng")
    ap.add_argument("--plan", choices=("active", "fresh"), default="active", help="which plan a sample races")
    args = ap.parse_args()
    summary = {}
    for opponent in args.opponents.split(","):
        errors: dict[str, list[np.ndarray]] = {name: [] for name in [*MODELS, "constant speed and offset"]}
        for seed, lanes in ((0, (2, 3)), (1, (3, 2))):
            samples, positions, world = race(args.track, opponent, lanes, seed, args.plan == "fresh")
            context = RaceContext(world.track, world.params.kart, 0, 2, world.lane_change_limit, seed)
            for sample in samples:
                if sample.step + max(HORIZONS) >= len(positions):
                    continue
                truth = positions[[sample.step + h for h in HORIZONS]]
                first = predict(world, sample, FIXED_LINE_TRACKING, context)
                if first is None:
                    continue
                errors["constant speed and offset"].append(np.hypot(*(constant_guess(world, sample) - truth).T))
                for name, model in MODELS.items():
                    guess = first if model is FIXED_LINE_TRACKING else predict(world, sample, model, context)
                    assert guess is not None
                    errors[name].append(np.hypot(*(guess - truth).T))
        rows = {}
        for name, values in errors.items():
            table = np.array(values)
            rows[name] = {
                f"{h * 0.02:.1f}s": {
                    "mean": round(float(table[:, i].mean()), 3),
                    "p90": round(float(np.percentile(table[:, i], 90)), 3),
                }
                for i, h in enumerate(HORIZONS)
            }
        summary[opponent] = {"samples": len(errors["constant speed and offset"]), "error_m": rows}
        count = summary[opponent]["samples"]
        print(f"\n{opponent} on {args.track}, {args.plan} plans: {count} samples in reach (both start lanes)")
        print(f"  {'model of the other kart':42s} " + "  ".join(f"{h * 0.02:.1f} s mean / p90" for h in HORIZONS))
        for name, row in rows.items():
            cells = "  ".join(f"{row[k]['mean']:6.2f} / {row[k]['p90']:5.2f}   " for k in row)
            print(f"  {name:42s} {cells}", flush=True)
    print(json.dumps(summary))


if __name__ == "__main__":
    main()
