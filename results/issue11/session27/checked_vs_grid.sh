#!/bin/sh
# Session 27: mcts-lqng with the rollout check (depth 3) and as registered (depth 0) against the paper grid's other
# opponents, 4 races per track (seeds 0-3: two starts from each lane), one worker. Run from the repo root:
#   sh results/issue11/session27/checked_vs_grid.sh [CODE]   (CODE: a checkout to run, default this one)
CODE=${1:-$PWD}
S=$CODE/results/issue11/session26/checked_series.py
O=$PWD/results/issue11/session27/vs_grid
PY=$PWD/.venv/bin/python
mkdir -p $O
export PYTHONPATH=$CODE
for opponent in e2e fixed-rl mcts-rl; do
  for track in complex oval; do
    for depth in 0 3; do
      (cd "$CODE" && $PY $S --track $track --opponent $opponent --depth $depth --races 4 --workers 1) \
        > $O/${track}_${opponent}_depth${depth}.jsonl 2>>$O/errors.txt
    done
  done
done
