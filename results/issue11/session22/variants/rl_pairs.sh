#!/bin/sh
# mcts-lqng's pairs with the RL agents (the grid's), seeds 0 and 1 (one start from each lane), settings in TRACKER.
S=results/issue11/session22/variants/scan.py
for pair in "complex fixed-rl" "complex mcts-rl" "complex e2e" "oval mcts-rl" "oval fixed-rl" "oval e2e"; do
    set -- $pair
    .venv/bin/python $S "$1" "$2" "${SEEDS:-0,1}" 2 2>>/tmp/pairs_err.txt | grep -v "^# TRACKER"
done
