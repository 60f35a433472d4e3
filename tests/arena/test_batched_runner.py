"""The batched runner (:func:`arena.race.run_jobs`, :func:`controllers.race.run_races`) against the per-race runner
(:func:`arena.race.run_job`): a small tournament of every registered agent on two tracks gives every race the same
result, lap times and replay, bit for bit; a user's controller with no batch path races in a batched tournament;
chunks keep to one track and to their size."""

from __future__ import annotations

from collections.abc import Iterator
from dataclasses import replace
from typing import Any

import numpy as np
import pytest
from support.constant_driver import ConstantDriver

from arena.race import RaceJob, run_job, run_jobs
from arena.tournament import MemoryStore, TournamentSpec, chunks, run_tournament
from controllers import registry
from controllers.base import RaceContext
from controllers.lane_follower import LaneFollowerController
from controllers.race import BatchDriver, RaceSpec, decide, run_races
from controllers.registry import ControllerSpec, controller_names, register
from sim_core.observation import observe
from sim_core.params import kart_preset
from sim_core.track_io import get_track
from sim_core.world import World

pytestmark = pytest.mark.slow


def without_wall_time(plans: list[dict[str, Any]]) -> list[dict[str, Any]]:
    """Recorded plans without the search's wall time (``seconds``), which no two runs share."""
    return [{**p, "plan": {k: v for k, v in p["plan"].items() if k != "seconds"}} for p in plans]


def test_a_small_tournament_of_every_agent_gives_each_race_its_result_alone() -> None:
    """Every pair of the registered agents on oval and complex (start lanes alternating, varied conditions drawn
    from each race's seed: launch delays, wear, imprecision), 2 s races: the batched runner's races equal the same
    jobs run one by one, to the bit."""
    spec = TournamentSpec(
        agents=tuple(controller_names()), races_per_pair=1, time_limit=2.0, seed=11, conditions="varied"
    ).validate()
    jobs = spec.jobs()
    assert len({job.track for job in jobs}) == 2 and len(jobs) == 2 * len(spec.pairs())
    batched = run_jobs(jobs, record=True)
    for job, together in zip(jobs, batched, strict=True):
        alone = run_job(job, record=True)
        assert together.job == job
        assert together.result == alone.result, job
        assert together.lap_times == alone.lap_times, job
        assert together.replay is not None and alone.replay is not None
        assert np.array_equal(np.asarray(together.replay["poses"]), np.asarray(alone.replay["poses"])), job
        assert without_wall_time(together.replay["plans"]) == without_wall_time(alone.replay["plans"]), job


def test_lane_followers_decide_in_one_call_and_each_gets_its_own_inputs() -> None:
    """The lane follower's batch path: drivers grouped by track, kart and parameters; one vectorised call gives
    each driver the action its own ``act`` gives."""
    specs = [
        RaceSpec("complex", ("lane-follower", "lane-follower"), seed=s, start_lanes=(1 + s, 4 - s)) for s in (0, 1)
    ]
    outcomes = run_races([replace(spec, time_limit=2.0) for spec in specs])
    assert all(o.result.duration == pytest.approx(2.0, abs=0.03) for o in outcomes)
    drivers = [LaneFollowerController() for _ in range(4)]
    world = World(get_track("complex"), 2, 2)
    world.reset(races=1, start_lanes=(1, 4))
    observations = observe(world, 0) + observe(world, 1)
    for i, driver in enumerate(drivers):
        driver.reset(RaceContext(world.track, kart_preset("paper"), i % 2, 2, world.lane_change_limit, i))
    assert len({d.batch_key() for d in drivers}) == 1 and isinstance(drivers[0], BatchDriver)
    together = decide(drivers, observations)
    alone = [LaneFollowerController() for _ in range(4)]
    for i, driver in enumerate(alone):
        driver.reset(RaceContext(world.track, kart_preset("paper"), i % 2, 2, world.lane_change_limit, i))
    assert together == [driver.act(o) for driver, o in zip(alone, observations, strict=True)]
    assert len(set(together)) == 4  # four lanes, four different inputs


def test_races_that_cannot_share_a_world_are_refused() -> None:
    with pytest.raises(ValueError, match="share track"):
        run_races([RaceSpec("oval", ("lane-follower", "lane-follower")), RaceSpec("complex", ("lane-follower",) * 2)])


def test_chunks_keep_to_one_track_to_their_size_and_to_the_schedule() -> None:
    spec = TournamentSpec(agents=("a", "b", "c"), tracks=("oval", "complex"), races_per_pair=4, seed=1)
    jobs = spec.jobs()
    cut = chunks(jobs, 5, workers=2)
    assert [job for chunk in cut for job in chunk] == jobs
    assert all(len(chunk) <= 5 and len({job.track for job in chunk}) == 1 for chunk in cut)
    assert [len(c) for c in chunks(jobs[:4], 8, workers=2)] == [2, 2]  # both workers get races
    assert [len(c) for c in cut] == [4, 4, 4, 4, 4, 4]  # 12 races a track in at most 5: three of 4
    ten_a_track = [job for track in ("oval", "complex") for job in jobs if job.track == track][:10]
    ten_a_track += [job for job in jobs if job.track == "complex"][:10]
    assert [len(c) for c in chunks(ten_a_track, 8, workers=2)] == [5, 5, 5, 5]
    with pytest.raises(ValueError, match="batch"):
        chunks(jobs, 0)


class Coaster(ConstantDriver):
    """A user's driver with no batch path: straight ahead at 0.6 throttle."""

    name = "test-user-coaster"
    rate_hz = 10.0


@pytest.fixture
def coaster() -> Iterator[str]:
    register(ControllerSpec(name=Coaster.name, description="straight ahead", factory=Coaster))
    try:
        yield Coaster.name
    finally:
        registry._BY_NAME.pop(Coaster.name, None)  # other tests list the built-in controllers


def test_a_users_controller_without_a_batch_path_races_in_a_batched_tournament(coaster: str) -> None:
    spec = TournamentSpec(agents=(coaster, "lane-follower", "fixed-lqng"), tracks=("oval",), races_per_pair=2)
    spec = replace(spec, time_limit=3.0, seed=5, conditions="paper").validate()  # its commands applied as given
    assert not isinstance(Coaster(), BatchDriver)
    batched, one_by_one = MemoryStore(), MemoryStore()
    assert run_tournament(spec, batched, "t", backend="inline", batch=8) == spec.total == 6
    run_tournament(spec, one_by_one, "t", backend="inline", batch=1)
    assert batched.figures("t") == one_by_one.figures("t")
    moved = [r for r in batched.races["t"].values() if coaster in r.job.agents]
    assert len(moved) == 4 and all(isinstance(r.job, RaceJob) for r in moved)
    for race in moved:
        kart = race.job.agents.index(coaster)
        poses = np.asarray(race.replay["poses"])  # [step][kart] = [x, y, heading, speed, steer, throttle]
        assert np.hypot(*(poses[-1, kart, :2] - poses[0, kart, :2])) > 1.0  # it drove, through the per-kart path
        assert set(poses[1:, kart, 5]) == {0.6}
