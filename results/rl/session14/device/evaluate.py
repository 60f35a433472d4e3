"""Device: race candidate RL weights (CAND folders) on a track; one JSON line per race."""
import json, os, sys
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

sys.path.insert(0, "scripts")
import controllers.rl.policy as po
import controllers.rl.tracker as tr

ORIG = po.weights_folder


def one(task):
    label, agent, folder, opponent, track, seed = task
    def wf(name):
        return Path(folder) if (name == agent and folder) else ORIG(name)
    tr.weights_folder = wf
    po.weights_folder = wf
    import head_to_head
    names = (agent, opponent) if opponent != "solo" else (agent,)
    try:
        if opponent == "solo":
            from controllers.race import RaceSpec, run_race
            out = run_race(RaceSpec(track=track, controllers=names, seed=seed, start_lanes=(2,)))
            r = out.result
        else:
            r = head_to_head.race_once(track, names, seed, seed).result
        karts = [dict(finished=k.finished, time=None if k.finish_time is None else round(k.finish_time, 2),
                      faults=k.collisions_at_fault, illegal=k.illegal_lane_changes_per_step)
                 for k in r.karts]
        return json.dumps(dict(label=label, opponent=opponent, track=track, seed=seed, winner=r.winner, karts=karts))
    except Exception as exc:  # noqa: BLE001
        return json.dumps(dict(label=label, opponent=opponent, track=track, seed=seed, error=repr(exc)))


def main():
    tasks = [json.loads(line) for line in open(sys.argv[1])]
    with ProcessPoolExecutor(int(sys.argv[2])) as pool:
        for line in pool.map(one, [tuple(t) for t in tasks]):
            print(line, flush=True)


if __name__ == "__main__":
    main()
