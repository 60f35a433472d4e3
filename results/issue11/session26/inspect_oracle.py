"""The oracle's committed lanes (mpc.py's JSON) raced again: head to head, alone, and driven by fixed-lqng's
tracker instead of mcts-lqng's; path length, wall hits, the largest lateral acceleration, lap times."""

from __future__ import annotations

import json
import math
import os
import sys
from dataclasses import replace

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))

from oracle import ScriptedLanePlanner, oracle_driver

from controllers.base import RaceContext
from controllers.hierarchical import HierarchicalController
from controllers.lq.tracker import FIXED_LINE_TRACKING, LQNGTracker
from controllers.registry import make_controller
from sim_core.observation import observe
from sim_core.params import DT, SimParams, kart_preset
from sim_core.track_io import get_track
from sim_core.world import World


def race(track_name: str, drivers: list, start_lanes: tuple[int, ...]) -> dict:
    track = get_track(track_name)
    params = SimParams(kart=kart_preset("paper"))
    world = World(track, 1, len(drivers), params)
    world.reset(start_lanes=start_lanes)
    for k, d in enumerate(drivers):
        d.plan_latency = 0.1
        d.reset(RaceContext(track, params.kart, k, len(drivers), world.lane_change_limit, k))
    path = [0.0] * len(drivers)
    lat = [0.0] * len(drivers)
    prev = world.positions[0].copy()
    prev_v = world.speeds[0].copy()
    prev_h = world.headings[0].copy()
    while not world.done[0]:
        obs = observe(world, 0)
        actions = np.zeros((1, len(drivers), 2))
        for k, d in enumerate(drivers):
            if not obs[k].me.finished:
                a = d.act(obs[k])
                actions[0, k] = (a.steer, a.throttle)
        world.step(actions)
        pos, v, h = world.positions[0], world.speeds[0], world.headings[0]
        for k in range(len(drivers)):
            if not obs[k].me.finished:
                path[k] += float(np.hypot(*(pos[k] - prev[k])))
                dh = math.remainder(float(h[k] - prev_h[k]), 2 * math.pi) / DT
                lat[k] = max(lat[k], abs(dh * 0.5 * float(v[k] + prev_v[k])))
        prev, prev_v, prev_h = pos.copy(), v.copy(), h.copy()
    res = world.result(0)
    return {
        "time": [k.finish_time for k in res.karts],
        "winner": res.winner,
        "faults": [k.collisions_at_fault for k in res.karts],
        "illegal": [k.illegal_lane_changes for k in res.karts],
        "wall_hits": [k.wall_hits for k in res.karts],
        "contacts": [k.contacts for k in res.karts],
        "path_m": [round(p, 1) for p in path],
        "max_lateral_accel": [round(a, 2) for a in lat],
    }


def main() -> None:
    with open(sys.argv[1]) as fh:
        data = json.load(fh)
    lanes = {int(k): v for k, v in data["summary"]["lanes"].items()}
    track = data["summary"]["track"]
    fixed_on_oracle = HierarchicalController(
        "fixed-on-oracle-lanes", ScriptedLanePlanner(lanes), LQNGTracker(replace(FIXED_LINE_TRACKING))
    )
    rows = {
        "head_to_head_oracle_vs_fixed": race(track, [oracle_driver(lanes), make_controller("fixed-lqng")], (2, 3)),
        "oracle_lanes_alone": race(track, [oracle_driver(lanes)], (2,)),
        "line_alone_mcts_tracker": race(track, [oracle_driver()], (2,)),
        "fixed_lqng_alone": race(track, [make_controller("fixed-lqng")], (3,)),
        "mcts_lqng_alone": race(track, [make_controller("mcts-lqng")], (2,)),
        "oracle_lanes_fixed_tracker_alone": race(track, [fixed_on_oracle], (2,)),
    }
    for name, row in rows.items():
        print(name, json.dumps(row), flush=True)


if __name__ == "__main__":
    main()
