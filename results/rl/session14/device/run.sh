#!/bin/bash
# Device job: parallel RL fine-tunes, then validation races of each candidate. Usage: bash .dev/run.sh STEPS TRAIN_TIMEOUT
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
     --checkpoint-steps $CK --seed $seed --json $extra > $W/$name.log 2>&1; echo "$name rc=$? t=$(( $(date +%s) - T0 ))" >> $OUT/train_status.txt ) &
done < ${JOBS:-.dev/jobs.txt}
wait
echo "training done after $(( $(date +%s) - T0 )) s"; cat $OUT/train_status.txt
# export policies of the final model and each checkpoint
$PY - <<'PY'
import json, sys
from pathlib import Path
from controllers.rl.policy import export_policy
W = Path("/tmp/work")
tasks = []
for line in open(__import__("os").environ.get("JOBS", ".dev/jobs.txt")):
    if not line.strip():
        continue
    name, agent = line.split()[:2]
    cks = sorted((W / name / "checkpoints").glob("step_*"), key=lambda p: int(p.name[5:]))
    if (W / name / "model.zip").exists():
        folders = [W / name] + [c for c in cks if int(c.name[5:]) <= 2_000_100][-1:]
    else:
        folders = cks[-2:]
    for f in folders:
        try:
            export_policy(f)
        except Exception as exc:
            print("export failed", f, exc, file=sys.stderr); continue
        label = f"{name}/{f.name}" if f != W / name else f"{name}/final"
        opponents = ["fixed-lqng", "fixed-rl"] if agent == "mcts-rl" else ["fixed-lqng"]
        for opp in opponents:
            for seed in (0, 1):
                tasks.append([label, agent, str(f), opp, "results/rl/validation/validation.json", seed])
for agent in ("mcts-rl", "fixed-rl", "e2e"):
    for opp in (["fixed-lqng", "fixed-rl"] if agent == "mcts-rl" else ["fixed-lqng"]):
        for seed in (0, 1):
            tasks.append([f"shipped-{agent}", agent, "", opp, "results/rl/validation/validation.json", seed])
for opp in ("fixed-lqng", "fixed-rl"):
    for seed in (0, 1):
        tasks.append(["xfer-fixed-rl-weights", "mcts-rl", "controllers/rl/weights/fixed-rl", opp, "results/rl/validation/validation.json", seed])
with open("/tmp/tasks.jsonl", "w") as fh:
    for t in tasks:
        fh.write(json.dumps(t) + "\n")
print(len(tasks), "tasks")
PY
$PY .dev/evaluate.py /tmp/tasks.jsonl ${EVAL_WORKERS:-16} > $OUT/eval.jsonl 2> $OUT/eval.err
echo "eval done after $(( $(date +%s) - T0 )) s"; wc -l $OUT/eval.jsonl
cd $W && tar czf $OUT/cand_m1.tgz --exclude='checkpoints/*/model.zip' g40 g41 g42 g43 g44 g45 c46 *.log 2>/dev/null; tar czf $OUT/cand_m2.tgz --exclude='checkpoints/*/model.zip' c47 c48 c49 c50 c51 2>/dev/null; tar czf $OUT/cand_e.tgz --exclude='checkpoints/*/model.zip' e52 e53 2>/dev/null
ls -la $OUT
