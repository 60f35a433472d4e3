"""Two field studies of one schedule compared race by race: which agent took whose slots, the paired change in
collisions at fault on hand-made races, schedules that do not match refused, and a study read back from its
``field.json``."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from arena.field import FieldSpec
from arena.field_compare import agent_swaps, field_races, paired_changes
from arena.records import CHECKPOINT, PER_STEP, KartFigures, RaceFigures
from arena.reproduce_field import field_json


def _kart(agent: str, collisions: int, time: float | None = 80.0) -> KartFigures:
    return KartFigures(agent, time is not None, time, collisions, {PER_STEP: 0, CHECKPOINT: 0}, PER_STEP)


def _race(index: int, karts: tuple[KartFigures, ...], seed: int = 7) -> RaceFigures:
    return RaceFigures("oval", karts, index=index, seed=seed + index)


BASELINE = [
    _race(0, (_kart("a", 1), _kart("b", 0), _kart("a", 3))),
    _race(1, (_kart("a", 2), _kart("b", 2), _kart("a", 2, time=None))),
]
VARIANT = [
    _race(0, (_kart("a2", 0), _kart("b", 1), _kart("a2", 1, time=82.0))),
    _race(1, (_kart("a2", 1), _kart("b", 2), _kart("a2", 1))),
]


def test_each_agent_is_paired_with_the_agent_whose_slots_it_took() -> None:
    assert agent_swaps(BASELINE, VARIANT) == {"a2": "a", "b": "b"}


def test_the_paired_change_is_the_mean_of_each_races_difference() -> None:
    """a -> a2: race 0 (0 + 1) / 2 - (1 + 3) / 2 = -1.5, race 1 (1 + 1) / 2 - (2 + 2) / 2 = -1: mean -1.25; per
    kart-race 8 / 4 = 2 before and 3 / 4 after; times of the finishers only."""
    changes = {c.agent: c for c in paired_changes(BASELINE, VARIANT)}
    a2 = changes["a2"]
    assert (a2.baseline_agent, a2.races) == ("a", 2)
    assert a2.change == pytest.approx(-1.25)
    assert (a2.baseline_collisions, a2.collisions) == (pytest.approx(2.0), pytest.approx(0.75))
    assert (a2.baseline_time, a2.time) == (pytest.approx(80.0), pytest.approx(80.5))
    assert a2.change_ci95 is not None and a2.change_ci95.low <= -1.25 <= a2.change_ci95.high
    assert changes["b"].change == pytest.approx(0.5)


@pytest.mark.parametrize(
    ("variant", "says"),
    [
        (VARIANT[:1], "the baseline has 2 races"),
        ([VARIANT[0], _race(1, VARIANT[1].karts, seed=99)], "seed"),
        ([VARIANT[0], _race(1, (_kart("a2", 0), _kart("a2", 0), _kart("a2", 0)))], "a2 sits where"),
        ([_race(0, (_kart("c", 0), _kart("c", 0), _kart("c", 0))), _race(1, (_kart("c", 0),) * 3)], "a2 sits|c sits"),
    ],
)
def test_a_study_of_another_schedule_is_refused(variant: list[RaceFigures], says: str) -> None:
    with pytest.raises(ValueError, match=says):
        agent_swaps(BASELINE, variant)


def test_a_study_reads_back_from_its_field_json(tmp_path: Path) -> None:
    spec = FieldSpec(("a", "b"), ("oval",), field_size=3, races_per_track=2)
    (tmp_path / "field.json").write_text(json.dumps(field_json(spec, BASELINE, 1.0)))
    races = field_races(tmp_path)
    assert [r.agents for r in races] == [r.agents for r in BASELINE]
    assert [r.seed for r in races] == [7, 8]
    assert [[k.collisions_at_fault for k in r.karts] for r in races] == [[1, 0, 3], [2, 2, 2]]
    assert races[1].karts[2].finished is False
    assert paired_changes(races, BASELINE)[0].change == 0.0
