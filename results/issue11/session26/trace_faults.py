"""Where the collisions happened in an mpc.py race (its JSON): at each new contact or collision at fault, the
time, each kart's checkpoint, lane, lateral offset, speed, and who was ahead (centre-line progress)."""

from __future__ import annotations

import json
import os
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))

from oracle import fixed_on_lanes, load_lanes, oracle_driver, start_race

from sim_core.observation import observe


def main() -> None:
    path = sys.argv[1]
    with open(path) as fh:
        summary = json.load(fh)["summary"]
    opponent = summary["opponent"]
    opp = fixed_on_lanes(load_lanes(opponent[len("lanes:") :])) if opponent.startswith("lanes:") else opponent
    lanes = load_lanes(path)
    state = start_race(summary["track"], oracle_driver(lanes), tuple(summary["start_lanes"]), opponent=opp)
    seen = (0, 0, 0)
    while not state.done:
        state.advance()
        res = state.world.result(0).karts
        now = (res[0].collisions_at_fault, res[1].collisions_at_fault, res[0].contacts + res[1].contacts)
        if now != seen:
            views = observe(state.world, 0)[0].karts
            print(
                json.dumps(
                    {
                        "t": round(float(state.world.time[0]), 2),
                        "faults": now[:2],
                        "contacts": now[2],
                        "progress_gap_m": round(state.gap(), 2),
                        "karts": [
                            {
                                "cp": v.checkpoints_passed,
                                "lane": v.lane_now,
                                "lat": round(v.lateral, 2),
                                "v": round(v.speed, 2),
                                "rate_across": None,
                            }
                            for v in views
                        ],
                        "ego_planned_next": [lanes.get(views[0].checkpoints_passed + i) for i in (1, 2, 3)],
                        "straight": bool(state.world.track.section_is_straight(views[0].checkpoints_passed)),
                    }
                )
            )
            seen = now
    print(json.dumps({k: v for k, v in summary.items() if k != "lanes"}))


if __name__ == "__main__":
    main()
