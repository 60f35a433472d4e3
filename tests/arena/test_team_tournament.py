"""Team tournaments: two karts of each agent on one side-by-side row (every kart the same distance to the flag),
in mirrored pairs of races (the same seed, so the same conditions per slot, with the teams' slots swapped), scored
as the original's team races, a race counted once in the win table."""

from __future__ import annotations

from collections import Counter

import pytest

from arena.stats import tournament_stats
from arena.teams import team_result
from arena.tournament import TEAM_GRID_LANES, MemoryStore, TournamentSpec, run_tournament


def test_team_races_come_in_mirrored_pairs_and_give_each_team_every_slot_equally() -> None:
    spec = TournamentSpec(("mcts-rl", "e2e"), ("oval", "complex"), races_per_pair=6, team_size=2).validate()
    jobs = spec.jobs()
    assert len(jobs) == spec.total == 12
    slots: Counter[tuple[str, int]] = Counter()
    for first, second in zip(jobs[::2], jobs[1::2], strict=True):
        assert first.seed == second.seed and first.track == second.track
        assert first.start_lanes == second.start_lanes == TEAM_GRID_LANES
        assert first.teams == first.agents and second.teams == second.agents
        assert sorted(first.agents) == ["e2e", "e2e", "mcts-rl", "mcts-rl"]
        swapped = tuple("e2e" if a == "mcts-rl" else "mcts-rl" for a in first.agents)
        assert second.agents == swapped
        slots.update((agent, slot) for job in (first, second) for slot, agent in enumerate(job.agents))
    assert set(slots.values()) == {6}  # 2 tracks x 6 races: each team in each slot half the time
    assert len({job.seed for job in jobs if job.track == "oval"}) == 3  # three mirrored pairs per track
    assert all(job.background_planners == ("e2e",) for job in jobs)


def test_team_settings_that_cannot_be_fair_are_refused_by_name() -> None:
    odd = TournamentSpec(("mcts-rl", "e2e"), ("oval",), races_per_pair=5, team_size=2).problems()
    assert "mirrored pairs" in odd["races_per_pair"]
    too_many = TournamentSpec(("mcts-rl", "e2e"), ("oval",), races_per_pair=4, team_size=3).problems()
    assert "team_size must be 1 or up to 2" in too_many["team_size"]
    assert TournamentSpec.from_json(TournamentSpec(("a", "b"), team_size=2).to_json()).team_size == 2


@pytest.mark.parametrize("batch", [1, 4])
def test_a_team_tournament_is_scored_by_team_and_counts_a_race_once(batch: int) -> None:
    spec = TournamentSpec(
        ("fixed-lqng", "lane-follower"), ("oval",), races_per_pair=4, laps=1, time_limit=40.0, seed=3, team_size=2
    )
    store = MemoryStore()
    assert run_tournament(spec, store, "teams", backend="inline", record=False, batch=batch) == 4
    races = store.figures("teams")
    assert all(race.teams == race.agents and len(race.karts) == 4 for race in races)
    stats = tournament_stats(races).tracks["oval"]
    winners = Counter(team_result(race).winner for race in races)
    assert stats.wins["fixed-lqng"]["lane-follower"] == winners["fixed-lqng"]
    assert stats.wins["lane-follower"]["fixed-lqng"] == winners["lane-follower"]
    (pair,) = stats.team_pairs.values()
    assert pair.first.races == pair.second.races == 4 and pair.first.kart_races == 8
    assert pair.first.wins + pair.second.wins == sum(winners.values())
    assert pair.mirrored_pairs == 2 and 0 <= pair.split_pairs <= 2
    assert stats.pairs[frozenset(("fixed-lqng", "lane-follower"))].races == 4
    shown = stats.to_json()["teams"]
    assert shown[0]["teams"] == ["fixed-lqng", "lane-follower"] and shown[0]["mirrored_pairs"] == 2
