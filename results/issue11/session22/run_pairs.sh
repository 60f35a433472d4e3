#!/bin/sh
# mcts-lqng against each agent of the paper's grid on its two tracks, 50 races each (seeds 0..49, start lanes
# alternating), into pairs/: the same series as session 20's pairs/ and session 21's default_vs_rl.txt.
cd "$(dirname "$0")/../../.." || exit 1
mkdir -p results/issue11/session22/pairs
for track in complex oval; do
    for opponent in fixed-rl mcts-rl e2e fixed-lqng; do
        out="results/issue11/session22/pairs/${track}_${opponent}.txt"
        echo "# PYTHONPATH=\$PWD .venv/bin/python scripts/head_to_head.py --track $track --karts mcts-lqng,$opponent --races 50 --workers 2   (commit $(git rev-parse --short HEAD))" > "$out"
        PYTHONPATH=$PWD .venv/bin/python scripts/head_to_head.py --track "$track" --karts "mcts-lqng,$opponent" \
            --races 50 --workers 2 2>/dev/null >> "$out"
    done
done
