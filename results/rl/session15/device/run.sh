#!/bin/bash
# The lent 16-core machine's job (session 15): one `karting train` fine-tune per line of JOBS side by side (reward
# weights varied with --reward-weight), then screening on the validation circuit of each candidate (its final
# model; its checkpoint at or under 1.5M steps is exported for screening at home): a solo race, and races against fixed-lqng and (mcts-rl)
# fixed-rl, seeds 0-3. From the repo root, with the RL packages installed (the machine's Python 3.12 plus
# stable-baselines3, gymnasium, pettingzoo and osqp carried as wheels):
#   JOBS=results/rl/session15/device/round1_jobs.txt bash results/rl/session15/device/run.sh 2500000 300 500000
#   JOBS=results/rl/session15/device/round2_jobs.txt EVAL_TIMEOUT=90 bash results/rl/session15/device/run.sh 1600000 225 400000
# (round 1 stopped at 300 s, short of 2.5M: its candidates are the 2M checkpoints; round 2 starts from them, carried
# in .dev/). The candidates are packed before the screening races, so a cut-off call still returns them.
# Usage: run.sh STEPS TRAIN_TIMEOUT CKPT
STEPS=${1:-3000000}; TT=${2:-400}; CK=${3:-500000}
OUT=${OUT:-/tmp/out}; mkdir -p $OUT
export PYTHONPATH=/tmp/site:$PWD PYTHONUNBUFFERED=1 NUMBA_NUM_THREADS=1 OMP_NUM_THREADS=1 MKL_NUM_THREADS=1 OPENBLAS_NUM_THREADS=1
PY=${PY:-python3}
W=/tmp/work; mkdir -p $W
nproc; $PY -c "import stable_baselines3, osqp, numba, torch; print('imports ok', torch.__version__)" || exit 1
$PY -c "from controllers.rl.envs import make_config" # numba cache warm
T0=$(date +%s)
while read -r name agent src seed extra; do
  [ -z "$name" ] && continue
  ( timeout $TT $PY -m karting train $agent --out $W/$name --fine-tune-from $src --steps $STEPS --normalise-reward \
     --wall-hit-penalty 5 --near-wall-spawns 0.3 --near-wall-heading-deg 60 --log-std-init -1 --solo-spawns 0.3 \
     --gamma 0.995 --checkpoint-steps $CK --seed $seed --json $extra > $W/$name.log 2>&1; echo "$name rc=$? t=$(( $(date +%s) - T0 ))" >> $OUT/train_status.txt ) &
done < ${JOBS:?}
wait
echo "training done after $(( $(date +%s) - T0 )) s"; cat $OUT/train_status.txt
# export policies of the final model and each checkpoint
$PY - <<'PY'
import json, sys
from pathlib import Path
from controllers.rl.policy import export_policy
W = Path("/tmp/work")
tasks = []
for line in open(__import__("os").environ["JOBS"]):
    if not line.strip():
        continue
    name, agent = line.split()[:2]
    cks = sorted((W / name / "checkpoints").glob("step_*"), key=lambda p: int(p.name[5:]))
    if (W / name / "model.zip").exists():
        folders = [W / name] + [c for c in cks if int(c.name[5:]) <= 1_500_100][-1:]
    else:
        folders = cks[-2:]
    for f in folders:
        try:
            export_policy(f)
        except Exception as exc:
            print("export failed", f, exc, file=sys.stderr); continue
        label = f"{name}/{f.name}" if f != W / name else f"{name}/final"
        if f != W / name:
            continue  # exported for local screening only
        tasks.append([label, agent, str(f), "solo", "results/rl/validation/validation.json", 0])
        opponents = ["fixed-lqng", "fixed-rl"] if agent == "mcts-rl" else ["fixed-lqng"]
        for opp in opponents:
            for seed in range(4):
                tasks.append([label, agent, str(f), opp, "results/rl/validation/validation.json", seed])
for agent in ("mcts-rl", "e2e"):
    tasks.append([f"shipped-{agent}", agent, "", "solo", "results/rl/validation/validation.json", 0])
    for opp in (["fixed-lqng", "fixed-rl"] if agent == "mcts-rl" else ["fixed-lqng"]):
        for seed in range(4):
            tasks.append([f"shipped-{agent}", agent, "", opp, "results/rl/validation/validation.json", seed])
with open("/tmp/tasks.jsonl", "w") as fh:
    for t in tasks:
        fh.write(json.dumps(t) + "\n")
print(len(tasks), "tasks")
PY
# the candidates back in three parts (the device tool returns files of at most 16 MiB); checkpoints without model.zip
cut -d' ' -f1 $JOBS | split -l 6 - /tmp/part_; (cd $W && for p in /tmp/part_*; do tar czf $OUT/candidates_${p##*_}.tgz --exclude='checkpoints/*/model.zip' $(cat $p) $(sed 's/$/.log/' $p); done)
timeout ${EVAL_TIMEOUT:-900} $PY results/rl/session15/device/evaluate.py /tmp/tasks.jsonl ${EVAL_WORKERS:-16} > $OUT/eval.jsonl 2> $OUT/eval.err
echo "eval done after $(( $(date +%s) - T0 )) s"; wc -l $OUT/eval.jsonl
ls -la $OUT
