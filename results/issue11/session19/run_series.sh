#!/bin/sh
# The issue-11 series into this folder: 50 races per track (seeds 0..49, start lanes alternating), or with a
# spread start: run_series.sh SPREAD RACES KARTS (e.g. 0.25 100 fixed-lqng,fixed-lqng for the paired control).
# OUT: the folder to write into, relative to the repo root (default: this script's, results/issue11/session19).
cd "$(dirname "$0")/../../.." || exit 1
out_dir=${OUT:-results/issue11/session19}
spread=${1:-0}
races=${2:-50}
karts=${3:-mcts-lqng,fixed-lqng}
tag=""
[ "$spread" != "0" ] && tag="_spread${spread}_$(echo "$karts" | tr ',' '-')"
for track in complex oval complex-reversed oval-reversed results/issue11/kidney.json; do
    out="$out_dir/h2h_$(basename "$track" .json)$tag.txt"
    cmd="PYTHONPATH=\$PWD .venv/bin/python scripts/head_to_head.py --track $track --karts $karts --races $races --start-spread $spread --workers 2"
    echo "# $cmd   (commit $(git rev-parse --short HEAD))" > "$out"
    PYTHONPATH=$PWD .venv/bin/python scripts/head_to_head.py --track "$track" --karts "$karts" --races "$races" \
        --start-spread "$spread" --workers 2 2>/dev/null >> "$out"
done
