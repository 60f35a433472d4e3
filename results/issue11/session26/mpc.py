"""Receding-horizon oracle (issue 11, session 26): from each checkpoint of the race, race every lane sequence for
the next K checkpoints in the true simulator against the true opponent, keep the first lane of the best, go on.

The ego is mcts-lqng's tracker as registered (oracle.oracle_driver); the opponent fixed-lqng as registered. The
search's model is the race itself (the same simulator, the same opponent, deterministic), so no planner that
sends lanes to this tracker can see further within K checkpoints. Score of a sequence: the ego's progress lead
[s] at the checkpoint ``settle`` past the window's end (the time it crossed that checkpoint ahead of the
other kart), minus 1000 per collision at fault or illegal lane change of the ego in the rollout;
ties go to the racing line's lanes.

    PYTHONPATH=$PWD .venv/bin/python results/issue11/session26/mpc.py --track complex --lanes 2,3 --depth 3 \
        --workers 2 --out results/issue11/session26/mpc_complex_k3.json
"""

from __future__ import annotations

import argparse
import itertools
import json
import multiprocessing as mp
import os
import sys
import time

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))

from oracle import RaceState, finish, fixed_on_lanes, load_lanes, margin, oracle_driver, start_race

SNAPSHOT: RaceState | None = None
PENALTY = 1000.0


CLEAN = False  # --clean: every contact and every collision at fault by any kart counts against the ego too


def _counts(state: RaceState) -> tuple[int, int]:
    karts = state.world.result(0).karts
    k0 = karts[0]
    faults = k0.collisions_at_fault
    if CLEAN:
        faults = sum(k.collisions_at_fault + k.contacts for k in karts)
    return faults, k0.illegal_lane_changes


def rollout(task: tuple[dict[int, int], int]) -> tuple[float, int, int]:
    """(score, faults, illegal) of the snapshot continued with ego lanes ``lanes`` until both karts have crossed
    checkpoint ``target``: the score is the time [s] the ego crossed it ahead of the other kart (at most 3000
    steps; a kart that has not crossed by then counts as crossing at the end)."""
    lanes, target = task
    assert SNAPSHOT is not None
    state = SNAPSHOT.fork()
    planner = state.drivers[0].planner
    planner.lanes.update(lanes)  # type: ignore[attr-defined]
    state.drivers[0]._next_request = 0.0  # re-plan now (the plan applies after the usual 0.1 s)
    f0, i0 = _counts(state)
    karts = len(state.drivers)
    crossed = [-1] * karts
    for n in range(3000):
        if state.done:
            break
        state.advance()
        for k in range(karts):
            if crossed[k] < 0 and state.checkpoints(k) >= target:
                crossed[k] = n
        if min(crossed) >= 0:
            break
    crossed = [n if c < 0 else c for c in crossed]
    f1, i1 = _counts(state)
    faults, illegal = f1 - f0, i1 - i0
    # alone: the ego's own crossing time (the sooner the better)
    lead = 0.02 * (crossed[1] - crossed[0]) if karts > 1 else -0.02 * crossed[0]
    return lead - PENALTY * (faults + illegal), faults, illegal


def main() -> None:  # noqa: PLR0915 (a research script: one flat run)
    global SNAPSHOT, CLEAN
    ap = argparse.ArgumentParser()
    ap.add_argument("--track", default="complex")
    ap.add_argument("--lanes", default="2,3")
    ap.add_argument("--depth", type=int, default=3)
    ap.add_argument("--settle", type=int, default=2)
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--out", required=True)
    ap.add_argument(
        "--opponent",
        default="fixed-lqng",
        help="fixed-lqng (registered), lanes:FILE (fixed-lqng's tracker on an mpc.py run's lanes), none",
    )
    ap.add_argument(
        "--clean",
        action="store_true",
        help="penalise every contact and any kart's collision at fault, not only the ego's faults",
    )
    ap.add_argument("--ego-tracker", default="mcts", choices=("mcts", "fixed"))
    args = ap.parse_args()
    CLEAN = args.clean
    start_lanes = tuple(int(x) for x in args.lanes.split(","))

    def make_ego(lanes: dict[int, int] | None = None):  # type: ignore[no-untyped-def]
        return oracle_driver(lanes) if args.ego_tracker == "mcts" else fixed_on_lanes(lanes or {})

    def make_opponent():  # type: ignore[no-untyped-def]
        if args.opponent == "none":
            return None
        if args.opponent.startswith("lanes:"):
            return fixed_on_lanes(load_lanes(args.opponent[len("lanes:") :]))
        return args.opponent

    ego = make_ego()
    state = start_race(args.track, ego, start_lanes, opponent=make_opponent())
    planner = ego.planner
    n_lanes = state.world.track.n_lanes
    total = state.world.track.n_checkpoints * state.world.laps
    log = []
    t0 = time.time()
    ctx = mp.get_context("fork")
    w = 1
    while not state.done and w + 1 <= total:
        while not state.done and state.checkpoints(0) < w - 1:
            state.advance()
        if state.done:
            break
        window = [c for c in range(w + 1, w + 1 + args.depth) if c <= total]
        SNAPSHOT = state.fork()
        target = min(window[-1] + args.settle, total)
        line = {c: planner.line_lane(c) for c in window}  # type: ignore[attr-defined]
        tasks = [
            (dict(zip(window, seq)), target) for seq in itertools.product(range(1, n_lanes + 1), repeat=len(window))
        ]
        with ctx.Pool(args.workers) as pool:
            results = pool.map(rollout, tasks, chunksize=max(1, len(tasks) // (4 * args.workers)))
        scored = [
            (score + 0.001 * sum(lane == line[c] for c, lane in task[0].items()), task[0], score, f, i)
            for task, (score, f, i) in zip(tasks, results)
        ]
        best = max(scored, key=lambda r: r[0])
        base = next(r for r in scored if r[1] == line)
        chosen = best[1][window[0]]
        planner.lanes[window[0]] = chosen  # type: ignore[attr-defined]
        log.append(
            {
                "checkpoint": window[0],
                "gap_now_m": round(state.gap(), 3),
                "line_lane": line[window[0]],
                "lane": chosen,
                "best_seq": [best[1][c] for c in window],
                "best_gap": round(best[2], 3),
                "line_gap": round(base[2], 3),
                "clean": sum(1 for r in scored if r[3] == 0 and r[4] == 0),
            }
        )
        print(json.dumps(log[-1]), f"{time.time() - t0:.0f}s", flush=True)
        w += 1
    # the committed lanes raced from the start, as a plain race (the check that the oracle's race is real)
    lanes = dict(planner.lanes)  # type: ignore[attr-defined]
    replay = finish(start_race(args.track, make_ego(lanes), start_lanes, opponent=make_opponent()))
    baseline = finish(start_race(args.track, make_ego(), start_lanes, opponent=make_opponent()))
    summary = {
        "track": args.track,
        "start_lanes": start_lanes,
        "opponent": args.opponent,
        "ego_tracker": args.ego_tracker,
        "clean": args.clean,
        "depth": args.depth,
        "settle": args.settle,
        "oracle": replay,
        "oracle_margin_s": margin(replay),
        "line_only": baseline,
        "line_margin_s": margin(baseline),
        "lanes": {str(k): v for k, v in sorted(lanes.items())},
        "seconds": round(time.time() - t0, 1),
    }
    with open(args.out, "w") as fh:
        json.dump({"summary": summary, "log": log}, fh, indent=1)
    print(json.dumps(summary))


if __name__ == "__main__":
    main()
