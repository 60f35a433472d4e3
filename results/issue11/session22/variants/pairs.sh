#!/bin/sh
# Every pair mcts-lqng meets in the issue's series and the paper's grid, SEEDS (default 0-3) each, with the tracker
# settings in TRACKER (see scan.py). Usage: TRACKER='{...}' sh results/issue11/session22/variants/pairs.sh [SEEDS]
seeds=${1:-0-3}
S=results/issue11/session22/variants/scan.py
for pair in "complex fixed-lqng" "complex fixed-rl" "complex mcts-rl" "complex e2e" "oval fixed-lqng" "oval mcts-rl" \
    "oval fixed-rl" "oval e2e" "complex-reversed fixed-lqng" "oval-reversed fixed-lqng" \
    "results/issue11/kidney.json fixed-lqng"; do
    set -- $pair
    .venv/bin/python $S "$1" "$2" "$seeds" 2 2>>/tmp/pairs_err.txt | grep -v "^# TRACKER"
done
