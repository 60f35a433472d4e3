#!/bin/sh
# The issue-11 series, one at a time: 50 races per track, start lanes alternating, seeds 0..49.
cd "$(dirname "$0")/../.." || exit 1
for track in complex oval complex-reversed oval-reversed results/issue11/kidney.json; do
    out="results/issue11/h2h_$(basename "$track" .json).txt"
    cmd="PYTHONPATH=\$PWD .venv/bin/python scripts/head_to_head.py --track $track --karts mcts-lqng,fixed-lqng --races 50"
    echo "# $cmd   (commit $(git rev-parse --short HEAD))" > "$out"
    PYTHONPATH=$PWD /work/main/.venv/bin/python scripts/head_to_head.py --track "$track" --karts mcts-lqng,fixed-lqng \
        --races 50 2>/dev/null >> "$out"
done
