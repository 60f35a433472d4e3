#!/bin/sh
# The simulation-checked prototype (verified.py, depth 3) from both start lanes of the given tracks, one race each
# (races are deterministic per start lane up to the planner's seed), one after another. Run from the repo root:
#   sh results/issue11/session26/verified_starts.sh complex-reversed oval-reversed
D=results/issue11/session26
for track in "$@"; do
  name=$(basename "$track" .json)
  for lanes in 2,3 3,2; do
    PYTHONPATH=$PWD .venv/bin/python $D/verified_race.py --depth 3 --lanes $lanes --track "$track" \
      > "$D/verified_${name}_lane${lanes%%,*}_depth3.log" 2>&1
  done
done
