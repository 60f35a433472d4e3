#!/bin/sh
# Session 26's run on the lent 16-core machine: receding-horizon oracles (mpc.py, depth 3). Writes into $OUT.
python3 -m pip install --no-deps --no-index -q --break-system-packages .whl/*.whl > "$OUT/env.txt" 2>&1
export PYTHONPATH=$PWD
nproc >> "$OUT/env.txt"
D=results/issue11/session26
# phase 1: fixed-lqng's tracker alone, its lanes searched (the best fixed line the search finds for it); the
# oracle from lane 3 against fixed-lqng as registered; the oracle from lane 2 on oval
python3 $D/mpc.py --track complex --lanes 3 --ego-tracker fixed --opponent none --workers 8 \
    --out "$OUT/mpc_complex_fixed_alone.json" > "$OUT/mpc_complex_fixed_alone.log" 2>&1 &
python3 $D/mpc.py --track complex --lanes 3,2 --workers 4 \
    --out "$OUT/mpc_complex_lane3.json" > "$OUT/mpc_complex_lane3.log" 2>&1 &
python3 $D/mpc.py --track oval --lanes 2,3 --workers 4 \
    --out "$OUT/mpc_oval_lane2.json" > "$OUT/mpc_oval_lane2.log" 2>&1 &
wait
# phase 2: the oracle from both lanes against fixed-lqng's tracker on that searched fixed line
python3 $D/mpc.py --track complex --lanes 2,3 --workers 8 --opponent "lanes:$OUT/mpc_complex_fixed_alone.json" \
    --out "$OUT/mpc_complex_lane2_vs_best_fixed.json" > "$OUT/mpc_complex_lane2_vs_best_fixed.log" 2>&1 &
python3 $D/mpc.py --track complex --lanes 3,2 --workers 8 --opponent "lanes:$OUT/mpc_complex_fixed_alone.json" \
    --out "$OUT/mpc_complex_lane3_vs_best_fixed.json" > "$OUT/mpc_complex_lane3_vs_best_fixed.log" 2>&1 &
wait
