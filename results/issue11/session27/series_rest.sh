#!/bin/sh
# Session 27: the rest of the five 50-race series of mcts-lqng with rollout_check_depth=3 against fixed-lqng as
# registered (session 26 ran complex 0-49, complex-reversed 0-19, oval 0-9, oval-reversed 0-9, kidney 0-16).
# Seeds 10-17 of oval-reversed ran first on the code before the rollout tree (checked_series_oval-reversed_10-17),
# 18-49 on commit b362ef8, the other tracks on commit b362ef8 in a worktree (CODE below), so that the work going on
# in the checkout could not change them. The speed-ups of this session are bit for bit
# (results/issue11/session27/README.md), so the seeds run then and now are one series.
# Run from the repo root: sh results/issue11/session27/series_rest.sh [CODE]
CODE=${1:-$PWD}
S=$CODE/results/issue11/session26/checked_series.py
O=$PWD/results/issue11/session27
PY=$PWD/.venv/bin/python
export PYTHONPATH=$CODE
(cd "$CODE" && $PY $S --track complex-reversed --races 30 --first-seed 20 --workers 2) > $O/checked_series_complex-reversed_20-49.jsonl 2>>$O/series_rest.err
(cd "$CODE" && $PY $S --track oval --races 40 --first-seed 10 --workers 2) > $O/checked_series_oval_10-49.jsonl 2>>$O/series_rest.err
(cd "$CODE" && $PY $S --track results/issue11/kidney.json --races 33 --first-seed 17 --workers 2) > $O/checked_series_kidney_17-49.jsonl 2>>$O/series_rest.err
