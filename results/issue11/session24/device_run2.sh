#!/bin/sh
# Session 24's second run on the lent 16-core machine: grip_steer 0.98 with the alongside exemption (the code of
# this run's working tree), the paper grid's mcts-lqng races, the pass threshold and the first 20 races of each
# of the five series. Writes into $OUT.
python3 -m pip install --no-deps --no-index -q --break-system-packages .whl/*.whl > "$OUT/env.txt" 2>&1
export PYTHONPATH=$PWD
nproc >> "$OUT/env.txt"
V='{"grip_steer": 0.98}'
D=results/issue11/session24
s=$(date +%s)
TRACKER="$V" python3 results/issue11/session23/grid_pairs.py 16 mcts-lqng > "$OUT/grid_grip2.txt" 2>> "$OUT/env.txt"
echo "grid_grip2 $(( $(date +%s) - s )) s" >> "$OUT/env.txt"
TRACKER="$V" LABEL=grip2 python3 $D/pass_threshold.py --starts 16 --workers 16 > "$OUT/pass_threshold_grip2.txt" 2>> "$OUT/env.txt"
echo "pass_threshold $(( $(date +%s) - s )) s" >> "$OUT/env.txt"
for track in complex oval complex-reversed oval-reversed results/issue11/kidney.json; do
    echo "## $track"
    MCTS_TRACKER="$V" python3 $D/h2h_env.py --track $track --karts mcts-lqng,fixed-lqng --races 16 --workers 16 2>/dev/null
done > "$OUT/h2h_grip2_16.txt"
echo "h2h_grip2 $(( $(date +%s) - s )) s" >> "$OUT/env.txt"
