"""Regenerate the built-in track files in sim_core/tracks/.

* ``oval`` and ``complex``: converted from the per-checkpoint geometry of the paper's scenes in
  ``../shared/spec/tracks/*.json`` (centres, headings, straight/curve pieces, hand-set racing lanes).
* ``train-oval-small`` and ``train-oval-large``: two training ovals of different sizes laid from pieces
  (the paper trains its learned agents on two oval sizes).
* ``train-hairpins``: a training circuit with tight corners both ways (ours: the RL agents met complex's
  hairpins untrained and stuck against the outside wall).
* ``train-narrow-hairpins``: a 6 m wide training circuit with 180 deg hairpins of inside radius 2 and 1 m (ours:
  every other track is 10 m wide, and the RL agents ran wide into the 6 m wide hairpin of the imported
  ``brands-hatch`` and stopped against its wall).

Run from the repo root: ``.venv/bin/python scripts/make_tracks.py [--spec-dir ../shared/spec/tracks]``.
"""

from __future__ import annotations

import argparse
import json
import math
from pathlib import Path

from sim_core.track import Checkpoint, Section
from sim_core.track_builder import build_track, chain_track, hairpin_pieces, narrow_hairpin_pieces, oval_pieces
from sim_core.track_io import TRACKS_DIR, save_track

DESCRIPTIONS = {
    "oval": "The paper's oval: 24 checkpoints, 4 left-hand 90 deg corners (inside radius 15 m), 4 laps, L = 3.",
    "complex": "The paper's unseen complex track: 41 checkpoints, radii 15/7/5/1 m both ways, S-curves, 3 laps, L = 4.",
}


def lane_line_centre(sec: dict) -> tuple[float, float]:
    """Midpoint of a checkpoint's four lane points in the spec file."""
    xs = [sec[f"lane{k}_xy"][0] for k in range(1, 5)]
    ys = [sec[f"lane{k}_xy"][1] for k in range(1, 5)]
    return (round(sum(xs) / 4, 4), round(sum(ys) / 4, 4))


def convert_spec(path: Path) -> None:
    spec = json.loads(path.read_text())
    env = spec["meta"]["env"]
    checkpoints, sections = [], []
    for sec in spec["sections"]:
        checkpoints.append(
            # The checkpoint line is taken through the lane points (the scenes' trigger sits 0.407 m ahead).
            Checkpoint(
                lane_line_centre(sec), float(math.radians(sec["heading_ccw_from_x_deg"])), int(sec["optimalLane"])
            )
        )
        if sec["is_straight"]:
            sections.append(Section(is_straight=True, length=float(sec["trackLength"])))
        else:
            r = float(sec["trackInsideRadius"])
            angle = float(sec["turnDegrees"])
            sections.append(
                Section(
                    is_straight=False,
                    length=math.radians(angle) * (r + sec["trackWidth"] / 2),
                    inside_radius=r,
                    angle_deg=angle,
                    left_turn=bool(sec["leftTurn"]),
                )
            )
    name = path.stem
    track = build_track(
        name,
        checkpoints,
        sections,
        half_width=spec["sections"][0]["trackWidth"] / 2,
        laps=int(env["laps"]),
        lane_change_limit=int(env["MaxLaneChanges"]),
        description=DESCRIPTIONS.get(name, ""),
        meta={"source": "converted from shared/spec/tracks/" + path.name},
    )
    save_track(track, TRACKS_DIR / f"{name}.json")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--spec-dir", type=Path, default=Path("../shared/spec/tracks"))
    args = parser.parse_args()
    TRACKS_DIR.mkdir(exist_ok=True)
    for name in ("oval", "complex"):
        convert_spec(args.spec_dir / f"{name}.json")
    small = chain_track(
        "train-oval-small",
        oval_pieces(4, 1, 10.0),
        laps=1,
        lane_change_limit=4,
        description="Training oval, small: 40 m and 10 m straights, inside radius 10 m.",
    )
    large = chain_track(
        "train-oval-large",
        oval_pieces(8, 3, 20.0),
        laps=1,
        lane_change_limit=4,
        description="Training oval, large: 80 m and 30 m straights, inside radius 20 m.",
    )
    hairpins = chain_track(
        "train-hairpins",
        hairpin_pieces(),
        laps=1,
        lane_change_limit=4,
        description="Training circuit with a notch: corners of inside radius 5, 7 and 1 m, both ways (not in the "
        "paper's training set: its ovals have no corner under 10 m, complex has 1-5 m hairpins).",
    )
    narrow = chain_track(
        "train-narrow-hairpins",
        narrow_hairpin_pieces(width=6.0),
        width=6.0,
        laps=1,
        lane_change_limit=4,
        description="Training circuit 6 m wide: 180 deg left hairpins of inside radius 2 and 1 m, each followed by a "
        "right-left kink of inside radius 3 m (not in the paper's training set: every other track is 10 m wide).",
    )
    for track in (small, large, hairpins, narrow):
        save_track(track, TRACKS_DIR / f"{track.name}.json")
    print("wrote", sorted(p.name for p in TRACKS_DIR.glob("*.json")))


if __name__ == "__main__":
    main()
