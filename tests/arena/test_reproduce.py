"""The reproduction's checks (:mod:`arena.reproduce`): published results go stale when the condition set they
raced under changes, and the findings table reads a tournament's statistics as the paper's figures."""

from __future__ import annotations

import json
import shutil
from pathlib import Path

from arena.records import KartFigures, RaceFigures
from arena.reproduce import lane_decided_pairs, stale_conditions
from arena.stats import tournament_stats
from sim_core.conditions import condition_set

RESULTS = Path(__file__).resolve().parents[2] / "docs" / "results"


def test_published_results_go_stale_when_their_condition_set_changes(tmp_path: Path) -> None:
    folder = tmp_path / "varied"
    shutil.copytree(RESULTS / "varied", folder)
    assert stale_conditions(folder, "varied") == []
    manifest = json.loads((folder / "manifest.json").read_text())
    manifest["conditions"]["conditions"]["steer_noise"] = 0.5
    (folder / "manifest.json").write_text(json.dumps(manifest))
    assert stale_conditions(folder, "varied") == [
        "the 'varied' conditions changed since it raced (steer_noise): run it again"
    ]
    # a parameter the set gained since counts at its default (pace_range: every kart at pace 1, as before it)
    recorded = manifest["conditions"]["conditions"]
    recorded["steer_noise"] = condition_set("varied").steer_noise
    recorded.pop("pace_range", None)
    (folder / "manifest.json").write_text(json.dumps(manifest))
    assert stale_conditions(folder, "varied") == []
    recorded["pace_range"] = [0.9, 1.0]
    (folder / "manifest.json").write_text(json.dumps(manifest))
    assert "changed since it raced (pace_range)" in stale_conditions(folder, "varied")[0]
    del manifest["conditions"]["conditions"]
    (folder / "manifest.json").write_text(json.dumps(manifest))
    assert "records no 'varied' condition set" in stale_conditions(folder, "varied")[0]
    assert stale_conditions(tmp_path / "nothing-here", "varied") == []


def _race(index: int, winner_lane: int, agents: tuple[str, str] = ("a", "b")) -> RaceFigures:
    lanes = (2, 3) if index % 2 == 0 else (3, 2)
    times = tuple(60.0 if lanes[k] == winner_lane else 61.0 for k in range(2))
    karts = tuple(KartFigures(agent, True, t, 0, {"per_step": 0}, "per_step") for agent, t in zip(agents, times))
    return RaceFigures("oval", karts, index=index, start_lanes=lanes)


def test_a_pair_is_lane_decided_when_every_race_went_to_one_lane_but_not_when_one_agent_swept() -> None:
    by_lane = [_race(i, winner_lane=2) for i in range(6)]  # the kart in lane 2 always won: a 3-3 split
    assert lane_decided_pairs(tournament_stats(by_lane)) == ["a vs b on `oval`"]
    swept = [_race(i, winner_lane=2 if i % 2 == 0 else 3) for i in range(6)]  # a won every race, from both lanes
    assert lane_decided_pairs(tournament_stats(swept)) == []
    mixed = [*by_lane, _race(6, winner_lane=3)]  # one race won from lane 3
    assert lane_decided_pairs(tournament_stats(mixed)) == []
