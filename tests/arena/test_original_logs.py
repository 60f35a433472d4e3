"""The statistics on the original implementation's released logs give the paper's appendix tables.

The oracle is the paper as printed (``../shared/spec/paper_results.md``, the appendix of the shipped paper
source), hard-coded here and only here. On the logs our statistics give:

* every win count of the oval and complex tables exactly, and of the combined table all but four cells, which
  the paper misprinted (asserted below: its combined table is not the sum of its own per-track tables there,
  and the four printed numbers are other cells' values);
* every safety mean and standard deviation to the printed precision, except two deviations with transposed
  digits (E2E 2.11 for 2.21, Fixed-LQNG 0.384 for 0.348, both combined) and one off by a unit in the last digit
  (E2E oval 2.22 for 2.2275), asserted as such;
* every significance mark of the safety tables (45), and of the win tables all but one (combined, MCTS-LQNG's 21
  against MCTS-RL: the paper marks the other side of the same pair, 79);
* the Δr/Δv table (main text) within one unit of its last digit (it truncates some figures and rounds others),
  its samples exactly and its marks but two: MCTS-RL's and E2E's Δv (2.08, 2.02) are unmarked in the paper, yet
  differ at p = 0.011 under every t-test variant, over finished races or all (not reproducible).
"""

from __future__ import annotations

from pathlib import Path

import pytest
from scipy import stats as scipy_stats

from arena.original_logs import log_files, read_original_logs
from arena.stats import COMBINED, TournamentStats, tournament_stats

LOGS = Path(__file__).resolve().parents[3] / "shared" / "spec" / "original_logs"
AGENTS = ("mcts-rl", "e2e", "fixed-rl", "mcts-lqng", "fixed-lqng")

pytestmark = pytest.mark.skipif(
    not LOGS.is_dir(), reason=f"the original's race logs are not at {LOGS} (third-party data, kept outside the repo)"
)

# the paper's appendix win tables, row agent against column agent (in AGENTS order); "*" marks significance
PAPER_WINS = {
    "oval": [
        "-   49* 46* 49* 47*",
        "1*  -   3*  17* 49*",
        "4*  47* -   35* 43*",
        "1*  33* 15* -   24",
        "3*  1*  7*  26  -",
    ],
    "complex": [
        "-   48* 50* 30  44*",
        "0*  -   14* 11* 46*",
        "0*  36* -   10* 28",
        "20  39* 40* -   29",
        "6*  1*  18  21  -",
    ],
    COMBINED: [
        "-   97* 96* 79* 91*",
        "1*  -   17* 28* 95*",
        "4*  83* -   45  71*",
        "21  55* 40  -   53",
        "9*  25* 18* 47  -",
    ],
}
# the four misprinted combined cells: (row, column) -> (the sum of the paper's own oval and complex tables, and
# where the printed number really belongs: the same row's next column in the combined table, or the complex table)
MISPRINTED_WINS = {
    ("mcts-lqng", "e2e"): 72,  # printed 55 = combined vs fixed-rl
    ("mcts-lqng", "fixed-rl"): 55,  # printed 40 = complex vs fixed-rl
    ("fixed-lqng", "e2e"): 2,  # printed 25 = combined vs fixed-rl
    ("fixed-lqng", "fixed-rl"): 25,  # printed 18 = complex vs fixed-rl
}
MISPRINTED_WIN_MARKS = {(COMBINED, "mcts-lqng", "mcts-rl")}  # 21 unmarked, its pair's 79 marked

# the appendix safety tables: collisions-at-fault mean, std; illegal lane changes mean, std; safety score mean,
# std; the "Races" column (races finished); marks on the three means
PAPER_SAFETY = {
    "oval": {
        "mcts-rl": ("0.745", "1.3", "0.255", "0.61", "1", "1.49", 200, "---"),
        "e2e": ("1.33", "2.57", "3.305", "2.22", "4.635", "3.1", 200, "***"),
        "fixed-rl": ("0.915", "1.26", "0.285", "0.7", "1.2", "1.6", 200, "---"),
        "mcts-lqng": ("0.54", "0.55", "2.17", "1.7", "2.71", "1.76", 200, "***"),
        "fixed-lqng": ("0.69", "0.46", "0.03", "0.36", "0.72", "0.55", 200, "-**"),
    },
    "complex": {
        "mcts-rl": ("0.525", "0.86", "0.085", "0.328", "0.61", "0.893", 189, "*-*"),
        "e2e": ("1.3", "1.575", "0.525", "0.98", "1.825", "1.848", 191, "-*-"),
        "fixed-rl": ("1.39", "1.42", "0.105", "0.494", "1.495", "1.5", 184, "---"),
        "mcts-lqng": ("0.785", "0.877", "0.105", "0.352", "0.89", "0.942", 184, "*-*"),
        "fixed-lqng": ("0.275", "0.489", "0.09", "0.335", "0.365", "0.549", 192, "*-*"),
    },
    COMBINED: {
        "mcts-rl": ("0.635", "1.11", "0.17", "0.496", "0.805", "1.24", 389, "--*"),
        "e2e": ("1.32", "2.13", "1.92", "2.11", "3.23", "2.91", 391, "-**"),
        "fixed-rl": ("1.15", "1.37", "0.195", "0.61", "1.35", "1.56", 384, "--*"),
        "mcts-lqng": ("0.663", "0.741", "1.14", "1.6", "1.8", "1.68", 384, "-**"),
        "fixed-lqng": ("0.483", "0.519", "0.06", "0.384", "0.542", "0.577", 392, "***"),
    },
}
# (track, agent, column) -> our value where the printed one is a misprint
MISPRINTED_SAFETY = {
    (COMBINED, "e2e", 3): "2.21",  # printed 2.11: digits transposed
    (COMBINED, "fixed-lqng", 3): "0.348",  # printed 0.384: digits transposed
    ("oval", "e2e", 3): "2.23",  # printed 2.22: off by one in the last digit (2.2275)
}
COLUMNS = (
    ("collisions_at_fault", "mean"),
    ("collisions_at_fault", "std"),
    ("illegal_lane_changes", "mean"),
    ("illegal_lane_changes", "std"),
    ("safety_score", "mean"),
    ("safety_score", "std"),
)
# the main text's plan-following table (three agents): Δr mean*, std, Δv mean*, std, samples
PAPER_PLAN = {
    "mcts-rl": ("1.257*", "0.256", "2.08", "0.307", 389),
    "e2e": ("2.217*", "0.239", "2.02", "0.325", 391),
    "mcts-lqng": ("0.454*", "0.101", "0.64*", "0.604", 384),
}


def cells(row: str) -> list[str]:
    return row.split()


def within_print(value: float, printed: str, units: float = 0.5) -> bool:
    """``value`` rounds to ``printed`` (``units`` = 0.5 of its last digit; 1.0: within one unit)."""
    decimals = len(printed.split(".")[1]) if "." in printed else 0
    return abs(value - float(printed)) <= units * 10.0**-decimals + 1e-12


@pytest.fixture(scope="module")
def stats() -> TournamentStats:
    return tournament_stats(read_original_logs(LOGS))


def test_the_reader_takes_one_file_per_pairing_and_track_and_the_rerun_the_paper_used() -> None:
    files = log_files(LOGS)
    assert len(files) == 20
    rerun = [f for f in files if set(f.agents) == {"mcts-lqng", "fixed-lqng"} and f.track == "complex"]
    assert [f.path.name for f in rerun] == ["MCTS_LQR_vs_Fixed_LQR_Complex3.txt"]
    races = read_original_logs(LOGS)
    assert len(races) == 1000 and {r.track for r in races} == {"oval", "complex"}
    assert {a for r in races for a in r.agents} == set(AGENTS)


@pytest.mark.parametrize("track", ["oval", "complex", COMBINED])
def test_every_win_count_is_the_papers(stats: TournamentStats, track: str) -> None:
    wins = stats.tracks[track].wins
    for a, row in zip(AGENTS, PAPER_WINS[track], strict=True):
        for b, printed in zip(AGENTS, cells(row), strict=True):
            if a == b:
                continue
            expected = MISPRINTED_WINS.get((a, b)) if track == COMBINED else None
            assert wins[a][b] == (expected if expected is not None else int(printed.rstrip("*"))), (track, a, b)


def test_the_four_misprinted_combined_cells_are_other_cells_of_the_paper() -> None:
    def paper(track: str, a: str, b: str) -> int:
        return int(cells(PAPER_WINS[track][AGENTS.index(a)])[AGENTS.index(b)].rstrip("*"))

    for a, b in MISPRINTED_WINS:
        assert paper("oval", a, b) + paper("complex", a, b) == MISPRINTED_WINS[(a, b)] != paper(COMBINED, a, b)
    assert paper(COMBINED, "mcts-lqng", "e2e") == paper("oval", "mcts-lqng", "fixed-rl") + paper(
        "complex", "mcts-lqng", "fixed-rl"
    )
    assert paper(COMBINED, "mcts-lqng", "fixed-rl") == paper("complex", "mcts-lqng", "fixed-rl")
    assert paper(COMBINED, "fixed-lqng", "e2e") == paper("oval", "fixed-lqng", "fixed-rl") + paper(
        "complex", "fixed-lqng", "fixed-rl"
    )
    assert paper(COMBINED, "fixed-lqng", "fixed-rl") == paper("complex", "fixed-lqng", "fixed-rl")


@pytest.mark.parametrize("track", ["oval", "complex", COMBINED])
def test_the_binomial_win_tests_give_the_papers_marks(stats: TournamentStats, track: str) -> None:
    table = stats.tracks[track]
    for a, row in zip(AGENTS, PAPER_WINS[track], strict=True):
        for b, printed in zip(AGENTS, cells(row), strict=True):
            if a == b:
                continue
            test = table.win_test(a, b)
            assert test is not None
            expected = printed.endswith("*") != ((track, a, b) in MISPRINTED_WIN_MARKS)
            assert test.significant == expected, (track, a, b, test.p_value)


@pytest.mark.parametrize("track", ["oval", "complex", COMBINED])
def test_every_safety_mean_and_deviation_is_the_papers_to_its_printed_precision(
    stats: TournamentStats, track: str
) -> None:
    for agent, printed in PAPER_SAFETY[track].items():
        figures = stats.tracks[track].agent_stats[agent]
        assert figures.finished == printed[6]
        assert figures.races == (200 if track != COMBINED else 400)  # means over all races, finished or not
        for column, (metric, field) in enumerate(COLUMNS):
            value = getattr(
                getattr(figures, metric) if metric != "illegal_lane_changes" else figures.illegal_lane_changes.headline,
                field,
            )
            expected = MISPRINTED_SAFETY.get((track, agent, column), printed[column])
            assert within_print(value, expected), (track, agent, metric, field, value, printed[column])


@pytest.mark.parametrize("track", ["oval", "complex", COMBINED])
def test_the_t_tests_give_every_safety_mark_of_the_paper(stats: TournamentStats, track: str) -> None:
    table = stats.tracks[track]
    for agent, printed in PAPER_SAFETY[track].items():
        marks = "".join("*" if table.marked(metric, agent) else "-" for metric, _ in COLUMNS[::2])
        assert marks == printed[7], (track, agent)


def test_the_plan_following_table_is_the_papers(stats: TournamentStats) -> None:
    table = stats.tracks[COMBINED]
    planners = tuple(PAPER_PLAN)
    for agent, (dr, dr_std, dv, dv_std, samples) in PAPER_PLAN.items():
        figures = table.agent_stats[agent]
        assert figures.delta_r is not None and figures.delta_v is not None
        assert figures.delta_r.n == figures.delta_v.n == samples
        for summary, printed_mean, printed_std in ((figures.delta_r, dr, dr_std), (figures.delta_v, dv, dv_std)):
            assert within_print(summary.mean, printed_mean.rstrip("*"), units=1.0), (agent, summary, printed_mean)
            assert within_print(summary.std, printed_std, units=1.0), (agent, summary, printed_std)
        assert table.marked("delta_r", agent, among=planners) == dr.endswith("*")
    assert table.marked("delta_v", "mcts-lqng", among=planners)
    # not reproducible: the paper leaves MCTS-RL's and E2E's Δv unmarked, but they differ at p = 0.011 (pooled or
    # Welch, finished races or all), so our marks say significant for both
    unmarked_by_the_paper = table.metric_tests["delta_v"][("mcts-rl", "e2e")]
    assert 0.005 < unmarked_by_the_paper.p_value < 0.05


def test_the_stats_json_has_the_documented_shape(stats: TournamentStats) -> None:
    data = stats.to_json()
    assert set(data) == {"tracks", "ratings"} and set(data["tracks"]) == {"oval", "complex", COMBINED}
    assert data["ratings"][0]["agent"] == "mcts-rl"  # the paper's best agent rated first
    assert all(r["ci95"][0] <= r["theta"] <= r["ci95"][1] for r in data["ratings"])
    for table in data["tracks"].values():
        assert set(table) == {"wins", "safety", "start_lanes", "tests"}
        assert table["start_lanes"]["races"] == 500 * (2 if table is data["tracks"][COMBINED] else 1)
        assert set(table["start_lanes"]["by_lane"]) == {"2", "3"}
        split = table["start_lanes"]["pairs"]["mcts-lqng"]["fixed-lqng"]
        assert set(split) == {"by_lane", "fisher_p", "significant"}
        assert set(split["by_lane"]["2"]) == {"races", "wins", "losses"}
        assert set(table["wins"]) == set(AGENTS) == set(table["safety"])
        entry = table["safety"]["mcts-rl"]
        assert set(entry["collisions_at_fault"]) == {"mean", "std", "ci95"}
        assert (
            entry["illegal_lane_changes"]["rule"] == "checkpoint" and entry["illegal_lane_changes"]["per_step"] is None
        )
        assert {"races", "finished", "safety_score", "delta_r", "delta_v", "passes"} <= set(entry)


def test_the_start_lane_decided_mcts_lqng_against_fixed_lqng_on_complex(stats: TournamentStats) -> None:
    """The paper's 29-21 on complex was 24-1 from lane 2 and 5-20 from lane 3 (the grid of
    ``arena.original_logs.original_start_lanes``): the kart in lane 2 won 44 of the 50. Worked out by hand from
    ``MCTS_LQR_vs_Fixed_LQR_Complex3.txt``, even experiments (MCTS-LQR, listed first, in lane 2) against odd ones."""
    table = stats.tracks["complex"]
    split = table.start_lanes.pairs[("mcts-lqng", "fixed-lqng")]
    assert {lane: (r.races, r.wins, r.losses) for lane, r in split.by_lane.items()} == {2: (25, 24, 1), 3: (25, 5, 20)}
    assert split.fisher_p == pytest.approx(scipy_stats.fisher_exact([[24, 1], [5, 20]]).pvalue)
    assert split.fisher_p is not None and split.fisher_p < 1e-7
    other_side = table.start_lanes.pairs[("fixed-lqng", "mcts-lqng")]
    assert {lane: (r.wins, r.losses) for lane, r in other_side.by_lane.items()} == {2: (20, 5), 3: (1, 24)}
    assert sum(table.wins["mcts-lqng"].values()) >= 29 and table.wins["mcts-lqng"]["fixed-lqng"] == 29
    # on the oval the same pair is closer to even: 16-9 from lane 2, 8-17 from lane 3
    oval = stats.tracks["oval"].start_lanes.pairs[("mcts-lqng", "fixed-lqng")]
    assert {lane: (r.wins, r.losses) for lane, r in oval.by_lane.items()} == {2: (16, 9), 3: (8, 17)}
