"""Writes ``validation.csv``: a closed kart circuit in the racetrack-database CSV format (x_m, y_m, w_tr_right_m,
w_tr_left_m), made in session 10 to choose among RL training runs without racing on any track an issue
measures (complex, oval, kidney). Tighter and more varied corners than kidney's.

    python results/rl/validation/make_circuit.py && karting import-track results/rl/validation/validation.csv \
        --out results/rl/validation/validation.json --laps 3
"""

from pathlib import Path

import numpy as np

theta = np.linspace(0.0, 2.0 * np.pi, 480, endpoint=False)
radius = 48.0 * (1.0 + 0.25 * np.sin(3.0 * theta + 0.3) + 0.10 * np.cos(5.0 * theta + 1.0))
x, y = 1.15 * radius * np.cos(theta), radius * np.sin(theta)
rows = ["# x_m,y_m,w_tr_right_m,w_tr_left_m"] + [f"{a:.3f},{b:.3f},5.000,5.000" for a, b in zip(x, y, strict=True)]
Path(__file__).with_name("validation.csv").write_text("\n".join(rows) + "\n")
