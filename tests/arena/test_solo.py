"""Solo laps: the schedule, the figures from hand-built races, and a real race against the referee's own result."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from arena.race import FinishedRace, RaceJob, run_jobs
from arena.solo import SOLO_START_LANE, SOLO_TIME_LIMIT, publish_solo, solo_figures, solo_jobs
from controllers.race import RaceSpec, run_race
from sim_core.world import KartResult, RaceResult


def _finished(job: RaceJob, laps: tuple[float, ...], wall_hits: int, finished: bool = True) -> FinishedRace:
    kart = KartResult(0, finished, sum(laps), len(laps), 0, 0, 0, 0, wall_hits, 0, 0, None, None, 1)
    result = RaceResult((kart,), 0 if finished else None, sum(laps), True)
    return FinishedRace(job, result, 3, 1.0, None, (laps,))


def test_every_agent_races_alone_on_every_track_from_lane_2_with_its_own_seeds() -> None:
    jobs = solo_jobs(["a", "b"], ["oval", "complex"], races=3, seed=10, conditions="varied")
    assert len(jobs) == 12 and sorted(j.index for j in jobs) == list(range(12))
    assert all(len(j.agents) == 1 and j.start_lanes == (SOLO_START_LANE,) for j in jobs)
    assert all(j.time_limit == SOLO_TIME_LIMIT and j.conditions == "varied" for j in jobs)
    of_b_on_complex = [j.seed for j in jobs if j.agents == ("b",) and j.track == "complex"]
    assert of_b_on_complex == [10, 11, 12]
    with pytest.raises(ValueError, match="races"):
        solo_jobs(["a"], ["oval"], races=0)
    with pytest.raises(ValueError, match="at least one"):
        solo_jobs([], ["oval"])


def test_figures_take_the_best_lap_the_laps_after_the_first_and_every_wall_hit() -> None:
    jobs = solo_jobs(["a"], ["oval"], races=2)
    races = [_finished(jobs[1], (21.0, 18.0, 19.0), 1), _finished(jobs[0], (20.0, 18.5, 18.4), 2, finished=False)]
    (figures,) = solo_figures(races)
    assert (figures.agent, figures.track, figures.races, figures.finished) == ("a", "oval", 2, 1)
    assert figures.best_lap == 18.0
    assert figures.mean_flying_lap == pytest.approx((18.5 + 18.4 + 18.0 + 19.0) / 4)
    assert figures.wall_hits == 3 and figures.wall_hits_per_race == 1.5
    assert figures.to_json()["wall_hits_per_race"] == 1.5


def test_a_solo_race_gives_the_referees_own_figures() -> None:
    (job,) = solo_jobs(["lane-follower"], ["train-oval-small"])
    (figures,) = solo_figures(run_jobs([job], record=False))
    alone = run_race(RaceSpec("train-oval-small", ("lane-follower",), seed=0, start_lanes=(2,), time_limit=300.0))
    assert figures.finished == 1 and alone.result.karts[0].finished
    assert figures.best_lap == pytest.approx(min(alone.lap_times[0]), abs=1e-3)
    assert figures.wall_hits == alone.result.karts[0].wall_hits
    assert figures.mean_flying_lap is None  # a one-lap track has no lap after the first


def test_published_solo_laps_name_their_command_agents_and_every_figure(tmp_path: Path) -> None:
    jobs = solo_jobs(["lane-follower"], ["oval"])
    (figures,) = solo_figures([_finished(jobs[0], (21.0, 18.25, 19.0), 2)])
    command = "karting solo --agents lane-follower --tracks oval --publish OUT"
    publish_solo(tmp_path, [figures], {"tracks": ["oval"], "races": 1}, command, 90.0)
    readme = (tmp_path / "README.md").read_text()
    assert f"`{command}`" in readme and "| lane-follower | oval | 1/1 | 18.25 | 18.62 | 2.0 |" in readme
    manifest = json.loads((tmp_path / "manifest.json").read_text())
    assert manifest["kind"] == "solo" and [a["agent"] for a in manifest["agents"]] == ["lane-follower"]
    assert json.loads((tmp_path / "solo.json").read_text())["solo"] == [figures.to_json()]
