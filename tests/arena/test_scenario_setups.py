"""The tactics suite's other situations: karts abreast into a corner, a slower kart to get by with a rival close
behind, a 4-kart standing start; where their karts start, how an attempt is judged, and short real attempts."""

from __future__ import annotations

import json
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from arena.oracle import run_oracle_cells
from arena.scenario_report import markdown_report, publish
from arena.scenario_setups import attempt_specs, inside_lane, judge, longest_straight
from arena.scenario_spec import Cell, Scenario, load_scenario
from arena.scenarios import SuiteResult, cells_of, run_cells
from controllers.race import RaceOutcome, RaceSpec
from sim_core.track_io import get_track
from sim_core.world import DEFAULT_START_LANES, KartResult, RaceResult


def test_a_bad_scenario_of_the_new_kinds_says_what_is_wrong(tmp_path: Path) -> None:
    with pytest.raises(ValueError, match=r"gap_m must be -3 <= low <= high <= 3 m"):
        Scenario("abreast", "side-by-side", gap_m=(-1.0, 5.0))
    with pytest.raises(ValueError, match=r"karts must be in 2\.\.4"):
        Scenario("crowd", "start", karts=6)
    with pytest.raises(ValueError, match=r"backmarker: .*nope"):
        Scenario("traffic", "lapping", backmarker="nope")
    with pytest.raises(ValueError, match="carries its own pace"):
        Scenario("traffic", "lapping", backmarker="fixed-lqng@0.9")
    with pytest.raises(ValueError, match=r"rival_gap_m must be"):
        Scenario("traffic", "lapping", rival_gap_m=(1.0, 2.0))
    mine = Scenario("traffic", "lapping", tracks=("oval",), paces=(0.8,), rival_gap_m=(4.0, 5.0))
    path = tmp_path / "traffic.json"
    path.write_text(json.dumps(mine.to_json()))
    assert load_scenario(str(path)) == mine


def test_abreast_into_a_corner_the_ego_takes_the_inside_then_the_outside_and_the_inside_flips_with_the_track() -> None:
    scenario = load_scenario("side-by-side-corner")
    oval, reversed_oval = get_track("oval"), get_track("oval-reversed")
    # the oval driven the other way turns the other way: its corners' inside is the other middle lane
    assert inside_lane(oval, longest_straight(oval)[1] - 35.0) != inside_lane(
        reversed_oval, longest_straight(reversed_oval)[1] - 35.0
    )
    for name in ("oval", "complex"):
        track = get_track(name)
        specs = attempt_specs(scenario, Cell(scenario.name, name, "mcts-lqng", "fixed-lqng", 1.0), 4)
        for i, spec in enumerate(specs):
            ego, opponent = spec.placements  # type: ignore[misc]
            assert {ego.lane, opponent.lane} == {2, 3} and ego.speed == opponent.speed > 5.0
            assert abs(ego.progress - opponent.progress) <= 1.0  # abreast: within the scenario's gap_m
            assert (ego.lane == inside_lane(track, min(ego.progress, opponent.progress))) == (i % 2 == 0)
            lateral = track.lane_offsets(0)
            assert abs(lateral[ego.lane - 1] - lateral[opponent.lane - 1]) > 2 * 0.9  # room for two bodies


def test_on_the_oval_the_inside_lane_is_the_one_nearer_the_infield() -> None:
    """The oval is convex: the inside of its corners is toward the middle of the infield."""
    for name in ("oval", "oval-reversed"):
        track = get_track(name)
        _, end = longest_straight(track)
        s = (end - 35.0) % track.length
        point, tangent = track.point_at(s)
        normal = np.array([-tangent[1], tangent[0]])
        section = int(np.searchsorted(track.checkpoint_s, s, side="right")) - 1
        offsets = track.lane_offsets(section)
        infield = track.centre_xy.mean(axis=0)
        distance = {lane: float(np.linalg.norm(point + normal * offsets[lane - 1] - infield)) for lane in (2, 3)}
        assert inside_lane(track, s) == min(distance, key=distance.__getitem__)


def test_lapping_places_the_slower_kart_ahead_the_ego_behind_it_and_the_rival_behind_the_ego() -> None:
    scenario = load_scenario("lapping-straight")
    cell = Cell(scenario.name, "complex", "mcts-rl", "fixed-rl", 0.85)
    specs = attempt_specs(scenario, cell, 6)
    for spec in specs:
        assert spec.controllers == ("mcts-rl", "fixed-rl", "fixed-lqng@0.85")  # only the slower kart is paced
        ego, rival, slow = spec.placements  # type: ignore[misc]
        assert 10.0 <= slow.progress - ego.progress <= 20.0 and 3.0 <= ego.progress - rival.progress <= 6.0
        assert ego.lane == rival.lane == slow.lane and ego.speed == rival.speed == slow.speed
    assert len({spec.placements[0].progress - spec.placements[1].progress for spec in specs}) == 6  # type: ignore[index]


def test_the_start_puts_the_ego_in_every_grid_lane_once_in_as_many_attempts_as_karts() -> None:
    scenario = load_scenario("start-4-karts")
    specs = attempt_specs(scenario, Cell(scenario.name, "oval", "e2e", "fixed-rl", 0.95), 8)
    assert all(spec.placements is None for spec in specs)
    assert all(spec.controllers == ("e2e", "fixed-rl@0.95", "fixed-rl@0.95", "fixed-rl@0.95") for spec in specs)
    lanes = [spec.start_lanes for spec in specs]
    assert all(sorted(row) == [1, 2, 3, 4] for row in lanes)  # type: ignore[arg-type]
    assert [row[0] for row in lanes] == [*DEFAULT_START_LANES, *DEFAULT_START_LANES]  # type: ignore[index]
    three = replace(scenario, karts=3)
    assert [spec.start_lanes for spec in attempt_specs(three, Cell("s", "oval", "e2e", "e2e", 1.0), 3)] == [
        (2, 3, 1),
        (3, 2, 1),
        (1, 2, 3),
    ]


def _kart(kart: int, position: int, passes_of: tuple[int, ...], faults: int = 0) -> KartResult:
    return KartResult(
        kart, True, 60.0 + position, 2, 20, faults, 0, faults, 0, 0, 0, None, None, position,
        passes=sum(passes_of), passes_of=passes_of,
    )  # fmt: skip


def _outcome(*karts: KartResult) -> RaceOutcome:
    return RaceOutcome(RaceSpec(), RaceResult(karts, 0, 70.0, True), 0.1, None)


def test_an_attempt_is_judged_by_its_kind_from_the_places_and_the_passes_by_kart() -> None:
    # lapping: karts (ego, rival, slower kart)
    by_the_slow_kart = _outcome(_kart(0, 1, (0, 0, 1)), _kart(1, 2, (0, 0, 1), faults=1), _kart(2, 3, (0, 0, 0)))
    attempt = judge("lapping", by_the_slow_kart, 400)
    assert attempt.success and attempt.place == 1 and attempt.opponent_collisions_at_fault == 1
    assert attempt.time_to_pass == pytest.approx((400 + 1 - 100) * 0.02)
    passed_only_the_rival = _outcome(_kart(0, 2, (0, 1, 0)), _kart(1, 3, (0, 0, 1)), _kart(2, 1, (0, 0, 0)))
    assert not judge("lapping", passed_only_the_rival, 400).success
    rival_got_by = _outcome(_kart(0, 2, (0, 0, 1)), _kart(1, 1, (1, 0, 1)), _kart(2, 3, (0, 0, 0)))
    assert not judge("lapping", rival_got_by, 400).success
    field = [_kart(0, 2, (0, 1, 0, 0)), _kart(1, 1, (0, 0, 0, 0)), _kart(2, 3, ()), _kart(3, 4, ())]
    assert not judge("start", _outcome(*field), None).success and judge("start", _outcome(*field), None).place == 2
    field[0], field[1] = _kart(0, 1, ()), _kart(1, 2, ())
    assert judge("start", _outcome(*field), None).success
    abreast = _outcome(_kart(0, 1, (0, 0)), _kart(1, 2, (0, 0)))
    assert judge("side-by-side", abreast, None).success and judge("side-by-side", abreast, None).time_to_pass is None


def test_short_real_attempts_of_each_new_kind_race_and_report_the_egos_place(tmp_path: Path) -> None:
    """mcts-lqng gets by fixed-lqng at pace 0.85 with a full-pace fixed-lqng behind it in both attempts; a 4-kart
    start and an attempt abreast give places in range and no broken rule from the hierarchical ego."""
    lapping = replace(load_scenario("lapping-straight"), laps=1)
    (by,) = run_cells(lapping, cells_of(lapping, ["mcts-lqng"], ["fixed-lqng"], ["oval"], [0.85]), attempts=2)
    assert by.successes == 2 and by.mean_place == 1.0 and by.time_to_pass is not None
    start = load_scenario("start-4-karts")
    (grid,) = run_cells(start, cells_of(start, ["mcts-lqng"], ["lane-follower"], ["oval"]), attempts=2)
    abreast = load_scenario("side-by-side-corner")
    (side,) = run_cells(abreast, cells_of(abreast, ["mcts-lqng"], ["fixed-lqng"], ["oval"]), attempts=2)
    for figures, karts in ((grid, 4), (side, 2)):
        assert figures.mean_place is not None and 1.0 <= figures.mean_place <= karts
        assert figures.illegal_lane_changes_per_attempt == 0.0
    summary = SuiteResult(((lapping, (by,)), (start, (grid,))), 2, 0).to_json()
    assert summary["pass_threshold_r50"] == {}  # thresholds are over overtaking scenarios only
    report = markdown_report(summary)
    assert "ego's place [95% CI]" in report and "start, the ego leads the field at the end" in report
    assert "| lapping-straight | oval | mcts-lqng | fixed-lqng | 0.85 | 2 | 1.00 [0.34, 1.00]" in report
    summary["scenarios"]["lapping-straight"]["backmarker"] = "lane-follower"
    publish(summary, tmp_path / "published", ["mcts-lqng", "fixed-lqng"], 1.0)
    manifest = json.loads((tmp_path / "published" / "manifest.json").read_text())
    assert [a["agent"] for a in manifest["agents"]] == ["fixed-lqng", "lane-follower", "mcts-lqng"]  # the slower kart


def test_the_oracle_refuses_a_scenario_of_more_than_two_karts() -> None:
    start = load_scenario("start-4-karts")
    with pytest.raises(ValueError, match="the oracle races two karts"):
        run_oracle_cells(start, [Cell(start.name, "oval", "oracle", "fixed-lqng", 1.0)], 1)
