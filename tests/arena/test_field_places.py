"""Where a field's collisions at fault happen: hand-built places, and a real race whose re-simulation must find
every collision at fault the referee charged."""

from __future__ import annotations

from dataclasses import replace

import pytest

from arena.field_places import FaultPlace, fault_places, hotspot_lines, hotspots
from arena.race import run_jobs
from arena.reproduce_field import field_spec
from controllers.race import load_any_track


def test_hotspots_count_each_tracks_places_and_rank_the_busiest_checkpoints() -> None:
    places = [
        FaultPlace("oval", "a", 3.0, 7, 1),
        FaultPlace("oval", "b", 3.1, 7, 1),
        FaultPlace("oval", "a", 50.0, 7, 2),
        FaultPlace("oval", "b", 60.0, 2, 2),
        FaultPlace("oval", "a", 70.0, 5, 3),
        FaultPlace("complex", "a", 4.0, 1, 1),
    ]
    spots = hotspots("oval", places, top=2)
    assert (spots.faults, spots.first_lap, spots.top) == (5, 2, ((7, 3), (2, 1)))  # 2 before 5: checkpoint order
    assert hotspots("brands-hatch", places).faults == 0
    lines = hotspot_lines([spots, hotspots("brands-hatch", places)])
    assert "| `oval` | 5 | 2 (40%) | 7: 3 (60%), 2: 1 (20%) |" in lines
    assert "| `brands-hatch` | 0 | 0 | - |" in lines


def test_a_races_places_are_every_collision_at_fault_the_referee_charged() -> None:
    # the first 10 s of a field race on brands-hatch: eight karts reach its first hairpin together
    job = replace(next(j for j in field_spec(2).jobs() if j.track == "brands-hatch"), time_limit=10.0)
    (race,) = run_jobs([job], record=True)
    places = fault_places(race)
    charged = [k.collisions_at_fault for k in race.result.karts]
    assert sum(charged) > 0, "no collision at fault: the test would check nothing"
    assert len(places) == sum(charged)
    for agent in set(job.agents):
        assert sum(p.agent == agent for p in places) == sum(
            n for a, n in zip(job.agents, charged, strict=True) if a == agent
        )
    n = load_any_track("brands-hatch").n_checkpoints
    assert all(p.lap == 1 and 0 <= p.checkpoint < n and 0.0 < p.time <= 10.0 for p in places)
    with pytest.raises(ValueError, match="no replay"):
        fault_places(run_jobs([replace(job, time_limit=1.0)], record=False)[0])
