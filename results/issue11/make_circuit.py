"""Writes ``kidney.csv``: a closed kart circuit in the racetrack-database CSV format (x_m, y_m, w_tr_right_m,
w_tr_left_m), made once for issue 11 as an untuned test track (never raced before the series was run).

    python results/issue11/make_circuit.py && karting import-track results/issue11/kidney.csv \
        --out results/issue11/kidney.json --laps 3
"""

from pathlib import Path

import numpy as np

theta = np.linspace(0.0, 2.0 * np.pi, 400, endpoint=False)
radius = 55.0 * (1.0 + 0.28 * np.sin(2.0 * theta) + 0.12 * np.cos(3.0 * theta + 0.4))
x, y = radius * np.cos(theta), radius * np.sin(theta)
rows = ["# x_m,y_m,w_tr_right_m,w_tr_left_m"] + [f"{a:.3f},{b:.3f},5.000,5.000" for a, b in zip(x, y, strict=True)]
Path(__file__).with_name("kidney.csv").write_text("\n".join(rows) + "\n")
