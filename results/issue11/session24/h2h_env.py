"""``scripts/head_to_head.py`` with the LQNG trackers' presets changed from the environment, for measuring a
tracker setting before it is shipped: MCTS_TRACKER, a JSON object of ``LQNGParams`` fields set on mcts-lqng's
presets; FIXED_TRACKER, the same for fixed-lqng's. The presets are changed before the worker processes fork.

    MCTS_TRACKER='{"grip_steer": 0.98}' PYTHONPATH=$PWD .venv/bin/python results/issue11/session24/h2h_env.py \\
        --track complex --karts mcts-lqng,fixed-lqng --races 2 --workers 2
"""

import json
import os
import runpy
from dataclasses import replace

import controllers.registry as registry

mcts = json.loads(os.environ.get("MCTS_TRACKER", "{}"))
fixed = json.loads(os.environ.get("FIXED_TRACKER", "{}"))
if mcts:
    registry.CLOSE_FOLLOWING_TRACKING = replace(registry.CLOSE_FOLLOWING_TRACKING, **mcts)
    registry.MCTS_TRACKING = replace(registry.MCTS_TRACKING, **mcts)
if fixed:
    registry.FIXED_LINE_TRACKING = replace(registry.FIXED_LINE_TRACKING, **fixed)
runpy.run_path("scripts/head_to_head.py", run_name="__main__")
