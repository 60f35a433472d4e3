"""Racing-line optimisation time per track and the optimised line's lap time against the hand-set lanes.

Both lines are timed under the same speed-profile model (paper kart, tyre wear 0.25).
Run from the repo root: ``.venv/bin/python benchmarks/racing_line.py``; the last line is one JSON object.
"""

from __future__ import annotations

import json
import time

from controllers.racing_line import compute_racing_line, handset_line
from sim_core.params import PAPER_KART
from sim_core.track_io import get_track

REPEATS = 5


def main() -> None:
    seconds: dict[str, float] = {}
    ratios: dict[str, float] = {}
    for name in ("oval", "complex"):
        track = get_track(name)
        compute_racing_line(track, PAPER_KART)  # warm imports (the optimisation itself is never cached here)
        times = []
        for _ in range(REPEATS):
            t0 = time.perf_counter()
            line = compute_racing_line(track, PAPER_KART)
            times.append(time.perf_counter() - t0)
        handset = handset_line(track, PAPER_KART)
        seconds[name] = min(times)
        ratios[name] = line.lap_time / handset.lap_time
        print(
            f"{name}: {min(times) * 1000:.0f} ms (best of {REPEATS}); lap {line.lap_time:.2f} s optimised vs "
            f"{handset.lap_time:.2f} s hand-set; lanes {''.join(map(str, line.checkpoint_lanes))}"
        )
    print(
        json.dumps(
            {
                "max_seconds_per_track": round(max(seconds.values()), 4),
                "seconds_per_track": {k: round(v, 4) for k, v in seconds.items()},
                "lap_time_ratio_optimised_vs_handset": round(max(ratios.values()), 4),
                "lap_time_ratio_per_track": {k: round(v, 4) for k, v in ratios.items()},
            }
        )
    )


if __name__ == "__main__":
    main()
