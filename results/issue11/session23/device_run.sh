#!/bin/sh
# Session 23's run on the lent 16-core machine (Python 3.12, numba/numpy/scipy/torch there; osqp, jinja2 and
# markupsafe carried as cp312 wheels in .whl/): the paper grid's mcts-lqng races as shipped and with the drift
# variant, the variant's five series, then both spread series while time is left. Writes into $OUT.
python3 -m pip install --no-deps --no-index -q --break-system-packages .whl/*.whl > "$OUT/env.txt" 2>&1
export PYTHONPATH=$PWD
python3 -c "import numba, numpy, scipy, torch, osqp, sys; print(sys.version, numba.__version__, numpy.__version__, scipy.__version__, torch.__version__, osqp.__version__)" >> "$OUT/env.txt" 2>&1
nproc >> "$OUT/env.txt"
rm -rf /tmp/var && mkdir /tmp/var && cp -r . /tmp/var && (cd /tmp/var && patch -p1 < results/issue11/session23/variants/drift_other_rate_only.patch) >> "$OUT/env.txt" 2>&1
G=results/issue11/session23/grid_pairs.py
s=$(date +%s)
python3 $G 16 mcts-lqng > "$OUT/grid_base.txt" 2>> "$OUT/env.txt"
echo "grid_base $(( $(date +%s) - s )) s" >> "$OUT/env.txt"
(cd /tmp/var && PYTHONPATH=/tmp/var python3 $G 16 mcts-lqng) > "$OUT/grid_var.txt" 2>> "$OUT/env.txt"
echo "grid_var $(( $(date +%s) - s )) s" >> "$OUT/env.txt"
for track in complex oval complex-reversed oval-reversed results/issue11/kidney.json; do
    echo "## $track"
    (cd /tmp/var && PYTHONPATH=/tmp/var python3 scripts/head_to_head.py --track $track --karts mcts-lqng,fixed-lqng --races 50 --workers 16 2>/dev/null)
done > "$OUT/h2h_var.txt"
echo "h2h_var $(( $(date +%s) - s )) s" >> "$OUT/env.txt"
for a in "complex 0.5" "complex-reversed 0.25" "oval 0.25"; do
    set -- $a
    echo "## $1 $2"
    (cd /tmp/var && PYTHONPATH=/tmp/var python3 scripts/head_to_head.py --track $1 --karts mcts-lqng,fixed-lqng --races 100 --start-spread $2 --workers 16 2>/dev/null)
done > "$OUT/spread_var.txt"
echo "spread_var $(( $(date +%s) - s )) s" >> "$OUT/env.txt"
