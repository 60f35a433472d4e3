#!/bin/sh
# Session 17's series, one at a time: the issue-11 series (50 races per track, start lanes alternating, seeds
# 0..49) and the pass threshold (pass_threshold.py) on complex and oval.
cd "$(dirname "$0")/../../.." || exit 1
PY=${PY:-.venv/bin/python}
for track in complex oval complex-reversed oval-reversed results/issue11/kidney.json; do
    out="results/issue11/session17/h2h_$(basename "$track" .json).txt"
    echo "# PYTHONPATH=\$PWD $PY scripts/head_to_head.py --track $track --karts mcts-lqng,fixed-lqng --races 50 --workers 2   (commit $(git rev-parse --short HEAD))" > "$out"
    PYTHONPATH=$PWD $PY scripts/head_to_head.py --track "$track" --karts mcts-lqng,fixed-lqng --races 50 --workers 2 \
        2>/dev/null >> "$out"
done
for track in complex oval; do
    out="results/issue11/session17/pass_threshold_$track.txt"
    echo "# PYTHONPATH=\$PWD $PY results/issue11/session17/pass_threshold.py --track $track --races 6   (commit $(git rev-parse --short HEAD))" > "$out"
    PYTHONPATH=$PWD $PY results/issue11/session17/pass_threshold.py --track "$track" --races 6 2>/dev/null >> "$out"
done
