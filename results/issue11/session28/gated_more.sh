#!/bin/sh
# Session 28: more races of the gated check (the new default) against fixed-lqng, seeds 2-9 on each track, to
# compare race by race with the stored series of the ungated check (sessions 26-27).
#   sh results/issue11/session28/gated_more.sh [CODE]
CODE=${1:-$PWD}
S=$CODE/results/issue11/session26/checked_series.py
O=$PWD/results/issue11/session28/gated
PY=$PWD/.venv/bin/python
export PYTHONPATH=$CODE
for track in complex oval complex-reversed oval-reversed results/issue11/kidney.json; do
  name=$(basename $track .json)
  (cd "$CODE" && $PY $S --track $track --opponent fixed-lqng --depth 3 --races 8 --first-seed 2 --workers 1) \
    > $O/${name}_fixed-lqng_2-9.jsonl 2>>$O/errors.txt
done
