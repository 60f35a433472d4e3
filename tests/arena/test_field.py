"""Free-for-all fields: the rotation puts every agent in every grid slot equally often, races of one index share
their seed across tracks' schedules, the per-agent figures on hand-placed races, the slot wins, bad specs refused,
and a tiny study run through worker processes and written out."""

from __future__ import annotations

import json
from collections import Counter
from pathlib import Path

import pytest

from arena.field import FieldSpec, field_figures, places, row_effect, slot_wins
from arena.field_places import FaultPlace
from arena.records import CHECKPOINT, PER_STEP, KartFigures, RaceFigures
from arena.reproduce_field import field_spec, run_field, write_field
from sim_core.conditions import condition_set

FIVE = ("mcts-rl", "e2e", "fixed-rl", "mcts-lqng", "fixed-lqng")


def _kart(agent: str, time: float | None, collisions: int = 0, illegal: int = 0) -> KartFigures:
    return KartFigures(agent, time is not None, time, collisions, {PER_STEP: illegal, CHECKPOINT: 0}, PER_STEP)


def test_over_a_turn_of_the_rotation_each_agent_starts_from_each_slot_equally_often() -> None:
    spec = FieldSpec(FIVE, races_per_track=20)
    for start in (0, 10):  # five reversed pairs
        slots = Counter((slot, agent) for r in range(start, start + 10) for slot, agent in enumerate(spec.lineup(r)))
        assert set(slots.values()) == {2} and len(slots) == 8 * 5
    assert spec.lineup(0) == (*FIVE, *FIVE[:3])
    assert spec.lineup(1) == spec.lineup(0)[::-1]  # the pair's second race: the grid reversed
    assert spec.lineup(2)[0] == "e2e"
    assert spec.start_lanes == (2, 3, 1, 4, 2, 3, 1, 4)
    unpaired = FieldSpec(FIVE, races_per_track=10, reversed_pairs=False)
    slots = Counter((slot, agent) for r in range(5) for slot, agent in enumerate(unpaired.lineup(r)))
    assert set(slots.values()) == {1} and unpaired.lineup(1)[0] == "e2e"


def test_the_schedule_has_every_track_and_one_seed_per_reversed_pair() -> None:
    spec = FieldSpec(FIVE, tracks=("oval", "complex"), races_per_track=4, field_size=6)
    jobs = spec.jobs()
    assert [j.index for j in jobs] == list(range(8)) and spec.total == 8
    assert [j.track for j in jobs] == ["oval"] * 4 + ["complex"] * 4
    assert [j.seed for j in jobs[::2]] == [j.seed for j in jobs[1::2]] and len({j.seed for j in jobs}) == 4
    assert all(len(j.agents) == 6 and j.conditions == "varied-equal-distance" for j in jobs)
    assert jobs == FieldSpec(FIVE, tracks=("oval", "complex"), races_per_track=4, field_size=6).jobs()
    unpaired = FieldSpec(FIVE, tracks=("oval",), races_per_track=3, reversed_pairs=False).jobs()
    assert len({j.seed for j in unpaired}) == 3


@pytest.mark.parametrize(
    ("change", "says"),
    [
        ({"agents": ("e2e",)}, "two or more"),
        ({"agents": ("e2e", "e2e")}, "two or more"),
        ({"field_size": 9}, "field_size"),
        ({"field_size": 1}, "field_size"),
        ({"races_per_track": 0}, "races_per_track"),
        ({"races_per_track": 3}, "even for reversed pairs"),
    ],
)
def test_bad_specs_say_what_is_wrong(change: dict[str, object], says: str) -> None:
    values: dict[str, object] = {"agents": FIVE, **change}
    with pytest.raises(ValueError, match=says):
        FieldSpec(**values).validate()  # type: ignore[arg-type]


def test_per_agent_figures_and_slot_wins_on_placed_races() -> None:
    races = [
        RaceFigures("oval", (_kart("a", 80.0, 1), _kart("b", 79.0), _kart("a", None, 2, 1))),
        RaceFigures("oval", (_kart("b", 81.0, 0, 2), _kart("a", 80.5), _kart("b", 82.0, 1))),
        RaceFigures("oval", (_kart("a", None), _kart("b", None), _kart("a", None))),  # nobody finished
    ]
    figures = field_figures(races)
    a, b = figures["a"], figures["b"]
    assert (a.karts, a.finished, a.wins, a.races) == (5, 2, 1, 3)
    assert (b.karts, b.finished, b.wins, b.races) == (4, 3, 1, 3)
    assert a.collisions_at_fault == pytest.approx(3 / 5) and a.illegal_lane_changes == pytest.approx(1 / 5)
    assert b.collisions_at_fault == pytest.approx(1 / 4) and b.illegal_lane_changes == pytest.approx(2 / 4)
    assert a.finished_ci95 is not None and a.finished_ci95.low < 0.4 < a.finished_ci95.high
    assert slot_wins(races) == [0, 2, 0]


def test_the_row_effect_pairs_each_kart_with_itself_from_the_other_row() -> None:
    """Two reversed pairs of 8 karts (slots 0-3 the front row). Pair one: the order is the grid's both times, so a
    kart loses 4 places on average from the back row (slot 0: 1st, then 8th from slot 7: 7 places; slot 3: 4th,
    then 5th: 1). Pair two: the order is slot order reversed in the first race and the same karts' order in the
    second, so nobody gains or loses a place."""
    agents = ("a", "b", "a", "b", "a", "b", "a", "b")

    def race(index: int, order: tuple[int, ...], grid: tuple[str, ...]) -> RaceFigures:
        times = {slot: 80.0 + place for place, slot in enumerate(order)}
        return RaceFigures("oval", tuple(_kart(grid[s], times[s]) for s in range(8)), index=index)

    in_slot_order = tuple(range(8))
    races = [
        race(0, in_slot_order, agents),
        race(1, in_slot_order, agents[::-1]),
        race(2, in_slot_order[::-1], agents),
        race(3, in_slot_order, agents[::-1]),  # slot s here is slot 7 - s there: the same karts' order
    ]
    assert places(races[2]) == [8, 7, 6, 5, 4, 3, 2, 1]
    effect = row_effect(races)
    assert effect is not None and effect.pairs == 2
    assert effect.places_lost == pytest.approx((8 * 4 + 8 * 0) / 16)
    assert effect.per_agent["a"][0] == pytest.approx(2.0) and effect.per_agent["b"][0] == pytest.approx(2.0)
    assert effect.same_winner == 1  # pair one: a, then b won; pair two: b (from slot 7), then the same kart
    with pytest.raises(ValueError, match="not a reversed pair"):
        row_effect([races[0], race(1, in_slot_order, agents)])
    assert row_effect(races[:1]) is None  # no pair
    one_row = [RaceFigures("oval", (_kart("a", 80.0), _kart("b", 81.0), _kart("a", 82.0)), index=i) for i in (0, 1)]
    assert row_effect(one_row) is None  # a pair, but no kart changes rows


def test_the_study_races_the_paper_agents_unless_told_others() -> None:
    assert field_spec(2).agents == FIVE
    assert field_spec(2, agents=("e2e", "mcts-lqng")).agents == ("e2e", "mcts-lqng")
    with pytest.raises(KeyError, match="nobody"):
        field_spec(2, agents=("nobody", "mcts-lqng"))


def test_a_tiny_study_runs_in_worker_processes_and_is_written_out(tmp_path: Path) -> None:
    spec = FieldSpec(("lane-follower", "fixed-lqng"), ("oval",), field_size=5, races_per_track=2, time_limit=6.0)
    places: list[FaultPlace] = []
    races = run_field(spec.validate(), workers=2, places=places)
    assert [len(r.karts) for r in races] == [5, 5]
    assert [r.agents for r in races] == [spec.lineup(0), spec.lineup(1)]
    assert len(places) == sum(k.collisions_at_fault for r in races for k in r.karts)
    write_field(tmp_path, spec, races, 1.0, places=places)
    data = json.loads((tmp_path / "field.json").read_text())
    assert [h["track"] for h in data["collision_places"]["hotspots"]] == ["oval"]
    assert "## Where the collisions at fault happen" in (tmp_path / "README.md").read_text()
    assert set(data["tracks"]) == {"oval", "combined"} and len(data["races"]) == 2
    assert set(data["tracks"]["oval"]["agents"]) == {"lane-follower", "fixed-lqng"}
    manifest = json.loads((tmp_path / "manifest.json").read_text())
    assert manifest["kind"] == "field"
    assert manifest["conditions"]["conditions"] == condition_set(spec.conditions).to_json()  # the set's values
    readme = (tmp_path / "README.md").read_text()
    assert "| fixed-lqng |" in readme and "Wins by grid slot" in readme and "The front row, paired" in readme
    assert "--agents lane-follower,fixed-lqng" in readme  # the command that regenerates a study of other agents
    write_field(tmp_path / "again", spec, races, 1.0, baseline=tmp_path)  # against itself: no change
    again = json.loads((tmp_path / "again" / "field.json").read_text())
    assert [c["change"] for c in again["baseline"]["changes"]] == [0.0, 0.0]
    assert f"--baseline {tmp_path}" in (tmp_path / "again" / "README.md").read_text()
    assert data["row_effect"]["pairs"] == 1 and races[0].seed == races[1].seed
    assert row_effect(races[:1]) is None
