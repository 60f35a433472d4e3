"""``scripts/head_to_head.py`` with the LQNG trackers' settings changed from the environment (MCTS_TRACKER,
FIXED_TRACKER: see ``tracker_env.py``), for measuring a setting before it is shipped.

    MCTS_TRACKER='{"grip_steer": 0.98}' PYTHONPATH=$PWD .venv/bin/python results/issue11/session24/h2h_env.py \\
        --track complex --karts mcts-lqng,fixed-lqng --races 2 --workers 2
"""

import runpy
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).parent))
import tracker_env

tracker_env.apply()
runpy.run_path("scripts/head_to_head.py", run_name="__main__")
