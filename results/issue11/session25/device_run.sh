#!/bin/sh
# Session 25's run on the lent 16-core machine: the random search of random_search.py. Writes into $OUT.
python3 -m pip install --no-deps --no-index -q --break-system-packages .whl/*.whl > "$OUT/env.txt" 2>&1
export PYTHONPATH=$PWD
nproc >> "$OUT/env.txt"
python3 results/issue11/session25/random_search.py --configs 5000 --workers 16 --phase1-s 330 --deadline-s 445 \
    --finalists 15 --random-share 0.55 --seed 1000 --out "$OUT/random_search.jsonl" > "$OUT/summary.json" 2>> "$OUT/env.txt"
