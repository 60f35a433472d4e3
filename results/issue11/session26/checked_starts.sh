#!/bin/sh
# mcts-lqng with rollout_check_depth=3 from both start lanes of each track given, one race each (races are
# deterministic per start lane up to the planner's seed), against fixed-lqng as registered. From the repo root:
#   sh results/issue11/session26/checked_starts.sh complex oval >> results/issue11/session26/checked_starts.jsonl
for track in "$@"; do
  for lanes in 2,3 3,2; do
    PYTHONPATH=$PWD .venv/bin/python results/issue11/session26/checked_race.py --depth 3 --lanes $lanes \
      --track "$track" 2>/dev/null
  done
done
