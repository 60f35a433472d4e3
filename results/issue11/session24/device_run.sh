#!/bin/sh
# Session 24's run on the lent 16-core machine (Python 3.12; osqp, jinja2 and markupsafe carried as cp312 wheels
# in .whl/): mcts-lqng's tracker with grip_steer 0.98 (TRACKER) against the code as committed. Writes into $OUT.
python3 -m pip install --no-deps --no-index -q --break-system-packages .whl/*.whl > "$OUT/env.txt" 2>&1
export PYTHONPATH=$PWD
python3 -c "import numba, numpy, scipy, osqp, sys; print(sys.version, numba.__version__, numpy.__version__, scipy.__version__, osqp.__version__)" >> "$OUT/env.txt" 2>&1
nproc >> "$OUT/env.txt"
V='{"grip_steer": 0.98}'
D=results/issue11/session24
s=$(date +%s)
for track in complex oval complex-reversed oval-reversed results/issue11/kidney.json; do
    echo "## $track"
    MCTS_TRACKER="$V" python3 $D/h2h_env.py --track $track --karts mcts-lqng,fixed-lqng --races 50 --workers 16 2>/dev/null
done > "$OUT/h2h_grip.txt"
echo "h2h_grip $(( $(date +%s) - s )) s" >> "$OUT/env.txt"
TRACKER="$V" LABEL=grip python3 $D/pass_threshold.py --starts 16 --workers 16 > "$OUT/pass_threshold_grip.txt" 2>> "$OUT/env.txt"
LABEL=shipped python3 $D/pass_threshold.py --starts 16 --workers 16 > "$OUT/pass_threshold_shipped.txt" 2>> "$OUT/env.txt"
echo "pass_threshold $(( $(date +%s) - s )) s" >> "$OUT/env.txt"
TRACKER="$V" python3 results/issue11/session23/grid_pairs.py 16 mcts-lqng > "$OUT/grid_grip.txt" 2>> "$OUT/env.txt"
echo "grid_grip $(( $(date +%s) - s )) s" >> "$OUT/env.txt"
for track in complex oval complex-reversed oval-reversed results/issue11/kidney.json; do
    echo "## $track"
    MCTS_TRACKER="$V" FIXED_TRACKER="$V" python3 $D/h2h_env.py --track $track --karts mcts-lqng,fixed-lqng --races 50 --workers 16 2>/dev/null
done > "$OUT/h2h_grip_both.txt"
echo "h2h_grip_both $(( $(date +%s) - s )) s" >> "$OUT/env.txt"
