#!/bin/sh
# Session 28: mcts-lqng with the gated rollout check (depth 3, trust 0.15 m: the registry's defaults for the check)
# A: against e2e, fixed-rl and mcts-rl on complex and oval, seeds 0-3 (session 27's vs_grid races);
# B: against fixed-lqng, seeds 0-1 on each of the five series' tracks (the series' own first two races).
# Run from the repo root:  sh results/issue11/session28/gated_runs.sh A|B [CODE]
PART=$1
CODE=${2:-$PWD}
S=$CODE/results/issue11/session26/checked_series.py
O=$PWD/results/issue11/session28/gated
PY=$PWD/.venv/bin/python
mkdir -p $O
export PYTHONPATH=$CODE
if [ "$PART" = A ]; then
  for opponent in mcts-rl fixed-rl e2e; do
    for track in complex oval; do
      (cd "$CODE" && $PY $S --track $track --opponent $opponent --depth 3 --races 4 --workers 1) \
        > $O/${track}_${opponent}.jsonl 2>>$O/errors.txt
    done
  done
else
  for track in complex oval complex-reversed oval-reversed results/issue11/kidney.json; do
    name=$(basename $track .json)
    (cd "$CODE" && $PY $S --track $track --opponent fixed-lqng --depth 3 --races 2 --workers 1) \
      > $O/${name}_fixed-lqng.jsonl 2>>$O/errors.txt
  done
fi
