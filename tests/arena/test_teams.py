"""Team scoring (the original team experiment's parser rule) on hand-placed races: places pay 10 / 7.5 / 6 / 4,
a kart that did not finish scores 0 and takes no place, the fastest finisher's team wins, equal times go by kart
order, and the per-team figures with their intervals."""

from __future__ import annotations

import pytest

from arena.records import CHECKPOINT, KartFigures, RaceFigures
from arena.teams import rival_held, team_figures, team_result


def _kart(team: str, time: float | None, collisions: int = 0, lane_changes: int = 0) -> KartFigures:
    return KartFigures(team, time is not None, time, collisions, {CHECKPOINT: lane_changes}, CHECKPOINT)


def _race(*karts: tuple[str, float | None], index: int = 0) -> RaceFigures:
    figures = tuple(_kart(team, time) for team, time in karts)
    return RaceFigures("oval", figures, index=index, teams=tuple(team for team, _ in karts))


def test_places_pay_the_original_points_and_the_fastest_finishers_team_wins() -> None:
    result = team_result(_race(("a", 82.0), ("a", 80.5), ("b", 81.0), ("b", 83.0)))
    assert result.order == (1, 2, 0, 3)
    assert result.winner == "a"
    assert result.points == {"a": 10.0 + 6.0, "b": 7.5 + 4.0}
    assert result.points_winner == "a" and not result.tied


def test_an_unfinished_kart_scores_nothing_and_takes_no_place() -> None:
    """With b's second kart out the places pay 10 / 7.5 / 6: a's karts take 1st and 3rd (16), b's 2nd (7.5)."""
    result = team_result(_race(("a", 80.0), ("b", 81.0), ("a", 90.0), ("b", None)))
    assert result.points == {"a": 16.0, "b": 7.5}
    assert result.order == (0, 1, 2)


def test_the_race_winner_and_the_points_winner_can_differ_only_with_karts_unfinished() -> None:
    result = team_result(_race(("a", 80.0), ("a", None), ("b", 81.0), ("b", 82.0)))
    assert result.winner == "a"
    assert result.points == {"a": 10.0, "b": 7.5 + 6.0}
    assert result.points_winner == "b"
    nobody = team_result(_race(("a", None), ("a", None), ("b", None), ("b", None)))
    assert nobody.winner is None and nobody.points_winner is None and nobody.order == ()


def test_equal_times_are_placed_in_kart_order_and_flagged() -> None:
    result = team_result(_race(("b", 80.0), ("a", 80.0), ("a", 81.0), ("b", 82.0)))
    assert result.order == (0, 1, 2, 3) and result.winner == "b" and result.tied
    assert result.points == {"b": 14.0, "a": 13.5}


def test_a_race_without_teams_is_refused() -> None:
    with pytest.raises(ValueError, match="no team"):
        team_result(RaceFigures("oval", (_kart("a", 80.0), _kart("b", 81.0))))


def test_team_figures_count_wins_points_safety_and_unfinished_karts_per_kart_race() -> None:
    first = RaceFigures(
        "oval",
        (_kart("a", 80.0, collisions=1), _kart("a", 85.0, lane_changes=2), _kart("b", 81.0), _kart("b", None)),
        teams=("a", "a", "b", "b"),
    )
    second = _race(("a", 90.0), ("a", 91.0), ("b", 85.0), ("b", 86.0), index=1)
    figures = team_figures([first, second])
    a, b = figures["a"], figures["b"]
    assert (a.races, a.wins, b.wins) == (2, 1, 1)
    assert a.mean_points == pytest.approx(((10 + 6) + (6 + 4)) / 2)
    assert b.mean_points == pytest.approx((7.5 + (10 + 7.5)) / 2)
    assert a.kart_races == 4 and a.collisions == pytest.approx(0.25) and a.illegal_lane_changes == pytest.approx(0.5)
    assert a.safety == pytest.approx(0.75) and (a.unfinished, b.unfinished) == (0, 1)
    assert a.wins_ci95 is not None and a.wins_ci95.contains(0.5)


def test_teammate_contacts_are_counted_apart_and_unknown_where_not_recorded() -> None:
    """Karts 0 and 1 are team a, 2 and 3 team b: a's karts touched each other twice, b's once, and a touched b
    three times (not a team-mate contact). A race without contact records makes the count unknown."""

    def kart(team: str, time: float, contacts: tuple[int, ...] | None) -> KartFigures:
        return KartFigures(team, True, time, 0, {CHECKPOINT: 0}, CHECKPOINT, contacts_with=contacts)

    contacts = ((0, 2, 3, 0), (2, 0, 0, 0), (3, 0, 0, 1), (0, 0, 1, 0))
    karts = tuple(kart(t, 80.0 + i, c) for i, (t, c) in enumerate(zip("aabb", contacts, strict=True)))
    race = RaceFigures("oval", karts, teams=("a", "a", "b", "b"))
    figures = team_figures([race, race])
    assert figures["a"].teammate_contacts == 4 and figures["a"].teammate_contacts_per_race == 2.0
    assert figures["b"].teammate_contacts == 2 and figures["b"].to_json()["teammate_contacts_per_race"] == 1.0
    unrecorded = RaceFigures("oval", tuple(kart(t, 80.0 + i, None) for i, t in enumerate("aabb")), teams=race.teams)
    assert team_figures([race, unrecorded])["a"].teammate_contacts is None


def test_passes_between_teammates_count_both_ways_and_say_in_how_many_races() -> None:
    """a's kart 1 passed its team-mate kart 0 once and was passed back once; b's karts never passed each other,
    and a's kart 0 passed b's kart 2 (not between team-mates)."""

    def kart(team: str, time: float, passes: tuple[int, ...]) -> KartFigures:
        return KartFigures(team, True, time, 0, {CHECKPOINT: 0}, CHECKPOINT, passes_of=passes)

    passes = ((0, 1, 1, 0), (1, 0, 0, 0), (0, 0, 0, 0), (0, 0, 0, 0))
    karts = tuple(kart(t, 80.0 + i, p) for i, (t, p) in enumerate(zip("aabb", passes, strict=True)))
    busy = RaceFigures("oval", karts, teams=tuple("aabb"))
    quiet = RaceFigures("oval", tuple(kart(t, 80.0 + i, (0,) * 4) for i, t in enumerate("aabb")), teams=tuple("aabb"))
    figures = team_figures([busy, quiet])
    assert (figures["a"].teammate_passes, figures["a"].races_with_teammate_pass) == (2, 1)
    assert figures["a"].teammate_pass_share == 0.5
    assert (figures["b"].teammate_passes, figures["b"].teammate_pass_share) == (0, 0.0)


@pytest.mark.parametrize(
    ("karts", "held"),
    [
        ((("a", 80.0), ("a", 81.0), ("b", 81.9), ("b", 85.0)), {"a"}),  # a 1-2, b's first kart 0.9 s behind
        ((("a", 80.0), ("a", 81.0), ("b", 82.5), ("b", 85.0)), set()),  # the rival 1.5 s back: not on its tail
        ((("a", 80.0), ("b", 80.5), ("a", 81.0), ("b", 81.2)), set()),  # a's second kart not behind its mate
        ((("b", 79.0), ("a", 80.0), ("a", 80.4), ("b", 81.0)), {"a"}),  # held in 3rd, behind its mate in 2nd
        ((("a", 80.0), ("a", 80.3), ("b", None), ("b", 81.0)), {"a"}),  # the unfinished kart takes no place
        ((("a", 80.0), ("a", 81.0), ("b", 82.0), ("b", 85.0)), {"a"}),  # the gap exactly HOLD_GAP: held
    ],
)
def test_a_rival_is_held_for_a_teammate_from_directly_behind_it_within_a_second(
    karts: tuple[tuple[str, float | None], ...], held: set[str]
) -> None:
    race = _race(*karts)
    assert rival_held(race) == held
    figures = team_figures([race, _race(("b", 80.0), ("a", 85.0), ("b", 90.0), ("a", 95.0))])
    assert figures["a"].races_with_rival_held == len(held & {"a"}) and figures["b"].races_with_rival_held == 0
    assert figures["a"].rival_held_share == len(held & {"a"}) / 2
