"""The paper grid's races that one agent drives (session 22's tournament: five agents, oval and complex, 50 races
per pair, seed 0), run in parallel without the database: one line per race, then per-opponent wins and the agent's
collisions at fault. The races are the tournament's own jobs (same seeds, lanes and background planners), so the
lines compare race by race with any grid run from the same code. argv: [workers] [agent]. Environment: TRACKER, a
JSON object of ``LQNGParams`` fields set on mcts-lqng's registered tracker preset; ONLY, the pairings to run as
track:opponent, comma separated (default: all).

    PYTHONPATH=$PWD .venv/bin/python results/issue11/session23/grid_pairs.py 2 mcts-lqng
    TRACKER='{"yield_speed_margin": 1.0}' ONLY=complex:fixed-rl,complex:e2e \
        PYTHONPATH=$PWD .venv/bin/python results/issue11/session23/grid_pairs.py 2 mcts-lqng
"""

import os
import sys
from collections import defaultdict
from multiprocessing import Pool
from pathlib import Path

from arena.race import RaceJob, run_job
from arena.tournament import TournamentSpec

AGENTS = ("mcts-rl", "e2e", "fixed-rl", "mcts-lqng", "fixed-lqng")


def race(job: RaceJob) -> tuple[RaceJob, list[tuple[float | None, int, int, int]], int]:
    done = run_job(job, record=False)
    karts = [(k.finish_time, k.collisions_at_fault, k.illegal_lane_changes, k.passes) for k in done.result.karts]
    first = min(range(len(done.result.karts)), key=lambda k: done.result.karts[k].position)
    return job, karts, first


def main() -> None:
    workers = int(sys.argv[1]) if len(sys.argv) > 1 else 2
    agent = sys.argv[2] if len(sys.argv) > 2 else "mcts-lqng"
    # TRACKER's fields are set on every mcts-lqng tracker built (the workers are forked after this); since session
    # 24 the registry's parameter grip_steer would write over a changed preset
    sys.path.insert(0, str(Path(__file__).parents[1] / "session24"))
    import tracker_env

    tracker_env.apply()
    only = {tuple(x.split(":")) for x in os.environ["ONLY"].split(",")} if os.environ.get("ONLY") else None
    jobs = [j for j in TournamentSpec(agents=AGENTS, races_per_pair=50, seed=0).jobs() if agent in j.agents]
    if only is not None:
        jobs = [j for j in jobs if (j.track, next(a for a in j.agents if a != agent)) in only]
    tally: dict[tuple[str, str], list[int]] = defaultdict(lambda: [0, 0, 0, 0])  # wins, races, faults, illegal
    with Pool(workers) as pool:
        for job, karts, first in pool.imap(race, jobs, chunksize=1):
            me = job.agents.index(agent)
            won = first == me
            opponent = job.agents[1 - me]
            row = tally[(job.track, opponent)]
            row[0] += int(won)
            row[1] += 1
            row[2] += karts[me][1]
            row[3] += karts[me][2]
            kart_text = " | ".join(
                f"{a} {t:.2f}s f{f} i{i} p{p}" if t is not None else f"{a} dnf f{f} i{i} p{p}"
                for a, (t, f, i, p) in zip(job.agents, karts, strict=True)
            )
            print(f"race {job.index:4d} {job.track} lanes {job.start_lanes} won={int(won)} | {kart_text}", flush=True)
    total = [0, 0, 0, 0]
    for (track, opponent), (wins, races, faults, illegal) in sorted(tally.items()):
        print(f"{track:8s} vs {opponent:10s} wins {wins:2d}/{races} faults {faults:3d} illegal {illegal:3d}")
        total = [a + b for a, b in zip(total, (wins, races, faults, illegal), strict=True)]
    print(f"TOTAL {agent} wins {total[0]}/{total[1]} faults {total[2]} illegal {total[3]}")


if __name__ == "__main__":
    main()
