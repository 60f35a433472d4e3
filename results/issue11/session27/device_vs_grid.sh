#!/bin/sh
# For a session with the lent 16-core machine (not run in session 27): mcts-lqng with the rollout check (depth 3)
# and as registered (depth 0) against every opponent of the paper's grid, RACES races per opponent and track
# (seeds 0..RACES-1, start lanes alternating), every (opponent, track, depth) in its own process at once. Writes
# into $OUT. About 6 minutes of the machine with RACES=10 (a checked race: 20-200 s of one core). Run from the
# repo root with the osqp wheel installed (see results/issue11/session26/device_run.sh):
#   RACES=10 OUT=/tmp/out sh results/issue11/session27/device_vs_grid.sh
RACES=${RACES:-10}
S=results/issue11/session26/checked_series.py
export PYTHONPATH=$PWD
for opponent in fixed-lqng e2e fixed-rl mcts-rl; do
  for track in complex oval; do
    for depth in 0 3; do
      python3 $S --track $track --opponent $opponent --depth $depth --races $RACES --workers 1 \
        > "$OUT/${track}_${opponent}_depth${depth}.jsonl" 2>> "$OUT/errors.txt" &
    done
  done
done
wait
