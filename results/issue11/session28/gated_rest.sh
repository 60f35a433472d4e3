#!/bin/sh
# Session 28: the rest of the five series with mcts-lqng as registered (the gated check), seeds 10-49, track by
# track (complex first), to compare race by race with the stored series (compare_series.py).
#   sh results/issue11/session28/gated_rest.sh CODE TRACK...
CODE=$1
shift
S=$CODE/results/issue11/session26/checked_series.py
O=$PWD/results/issue11/session28/gated
PY=$PWD/.venv/bin/python
export PYTHONPATH=$CODE
for track in "$@"; do
  name=$(basename $track .json)
  (cd "$CODE" && $PY $S --track $track --opponent fixed-lqng --depth 3 --races 40 --first-seed 10 --workers 1) \
    > $O/${name}_fixed-lqng_10-49.jsonl 2>>$O/errors.txt
done
