#!/bin/sh
# Session 22's measurements, in order: the issue's five series, the paper's grid, the spread series, the pass
# threshold. Run from the repo root.
set -x
sh results/issue11/session22/run_series.sh
DB=/tmp/grid_s22.db
rm -f $DB
PYTHONPATH=$PWD .venv/bin/karting tournament run --id paper-grid-50-s22 --agents mcts-rl,e2e,fixed-rl,mcts-lqng,fixed-lqng \
    --tracks oval,complex --races-per-pair 50 --seed 0 --workers 2 --db $DB > /tmp/grid_s22.log 2>&1
PYTHONPATH=$PWD .venv/bin/karting tournament stats --id paper-grid-50-s22 --db $DB --json > results/issue11/session22/grid/paper_grid.json
.venv/bin/python scripts/grid_summary.py results/issue11/session22/grid/paper_grid.json > results/issue11/session22/grid/summary.md
for a in "complex 0.5" "complex-reversed 0.25" "oval 0.25"; do
    set -- $a
    out=results/issue11/session22/spread_$1_$2_mcts-lqng.txt
    echo "# PYTHONPATH=\$PWD .venv/bin/python scripts/head_to_head.py --track $1 --karts mcts-lqng,fixed-lqng --races 100 --start-spread $2 --workers 2   (commit $(git rev-parse --short HEAD))" > $out
    PYTHONPATH=$PWD .venv/bin/python scripts/head_to_head.py --track $1 --karts mcts-lqng,fixed-lqng --races 100 --start-spread $2 --workers 2 2>/dev/null >> $out
done
out=results/issue11/session22/pass_threshold_complex.txt
echo "# PYTHONPATH=\$PWD .venv/bin/python results/issue11/session22/pass_threshold.py --starts 16   (commit $(git rev-parse --short HEAD))" > $out
PYTHONPATH=$PWD .venv/bin/python results/issue11/session22/pass_threshold.py --starts 16 2>/dev/null >> $out
echo done > /tmp/wtB_done
