#!/bin/sh
# Session 25's second run on the lent 16-core machine: the found settings (setting_529.json, setting_511.json) in
# the five 50-race series against fixed-lqng, the paper grid's mcts-lqng races, a control series and a spread
# series. Writes into $OUT.
python3 -m pip install --no-deps --no-index -q --break-system-packages .whl/*.whl > "$OUT/env.txt" 2>&1
export PYTHONPATH=$PWD
D=results/issue11/session25
s=$(date +%s)
stamp() { echo "$1 $(( $(date +%s) - s )) s" >> "$OUT/env.txt"; }
series() {  # config, output name, extra args
    for track in complex oval complex-reversed oval-reversed results/issue11/kidney.json; do
        echo "## $track"
        MCTS_SETTING="$(cat $D/setting_$1.json)" python3 $D/setting_env.py scripts/head_to_head.py --track $track \
            --karts mcts-lqng,fixed-lqng --races 50 --workers 16 2>/dev/null
    done > "$OUT/$2"
    stamp "$2"
}
series 529 h2h_529.txt
MCTS_SETTING="$(cat $D/setting_529.json)" python3 $D/setting_env.py results/issue11/session23/grid_pairs.py 16 mcts-lqng \
    > "$OUT/grid_529.txt" 2>> "$OUT/env.txt"
stamp grid_529
MCTS_SETTING="$(cat $D/setting_529.json)" FIXED_TRACKER='{"grip_steer": 0.982, "lookahead_time": 0.532}' \
    python3 $D/setting_env.py scripts/head_to_head.py --track complex --races 50 --workers 16 \
    > "$OUT/control_529_complex.txt" 2>/dev/null
stamp control
MCTS_SETTING="$(cat $D/setting_529.json)" python3 $D/setting_env.py scripts/head_to_head.py --track complex --races 100 \
    --workers 16 --start-spread 0.5 > "$OUT/spread_529_complex.txt" 2>/dev/null
stamp spread
series 511 h2h_511.txt
