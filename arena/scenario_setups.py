"""Where a scenario's karts start and how an attempt is judged (:mod:`arena.scenarios`).

Kart 0 is always the ego and kart 1 the opponent of the cell; a ``lapping`` attempt has the slower kart as kart 2,
a ``start`` attempt the opponent's copies as karts 1 to ``karts - 1``.

* ``overtake`` / ``defend``: two karts rolling in the racing lane on the longest straight, ``gap_m`` apart;
* ``side-by-side``: the two abreast in the middle lanes, rolling into the corner at the end of the longest straight,
  the ego on its inside in even attempts and on its outside in odd ones (paired: attempt ``i`` of every cell has
  the same side), ``gap_m`` the ego's distance behind the opponent (negative: ahead);
* ``lapping``: the ego ``gap_m`` behind a slower kart (``backmarker`` at the cell's pace) with the opponent at full
  pace ``rival_gap_m`` behind the ego, all three rolling in the racing lane;
* ``start``: a standing start from the grid, the ego in each grid lane in turn (attempt ``i`` in lane
  ``DEFAULT_START_LANES[i % karts]``), the opponent's copies in the others.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from arena.scenario_spec import Cell, Kind, Scenario
from controllers.race import Placement, RaceOutcome, RaceSpec, load_any_track
from controllers.racing_line import optimise_racing_line
from sim_core.params import DT, PAPER_KART
from sim_core.state import PASS_HOLD_STEPS
from sim_core.track import Track
from sim_core.world import DEFAULT_START_LANES

STRAIGHT_CURVATURE = 1.0 / 150.0  # [1/m] the centre line is straight where it turns more gently than this
STRAIGHT_ENTRY = 20.0  # [m] "straight": the leader this far into the track's longest straight
CORNER_BEFORE = 35.0  # [m] "corner": the leader this far before the end of the longest straight
CORNER_STEP = 1.0  # [m] the steps in which the first corner ahead is looked for
ROLLING_FRACTION = 0.9  # of the leader's line speed there: the karts roll in at this speed
MIDDLE_LANES = (2, 3)  # side by side: lane 2 is left of lane 3 (sim_core.track.DEFAULT_LANE_FRACTIONS)


def longest_straight(track: Track) -> tuple[float, float]:
    """(start, end) [m] of centre-line progress of the track's longest straight (end may exceed the length when it
    runs over the line)."""
    straight = np.abs(track.centre_curvature) < STRAIGHT_CURVATURE
    if straight.all() or not straight.any():
        return 0.0, float(track.length)
    s = track.centre_s
    start = int(np.argmin(straight))  # a sample in a corner: runs are counted from there, wrapping once
    best, best_run, run_start = (0.0, 0.0), -1.0, None
    n = len(s)
    for step in range(1, n + 1):
        i = (start + step) % n
        here = s[i] + (track.length if start + step >= n else 0.0)
        if straight[i] and run_start is None:
            run_start = here
        elif not straight[i] and run_start is not None:
            if here - run_start > best_run:
                best, best_run = (run_start, here), here - run_start
            run_start = None
    return float(best[0]), float(best[1])


def lead_progress(scenario: Scenario, track: Track, room_behind: float) -> float:
    """[m] where the front kart of a placed start rolls: ``STRAIGHT_ENTRY`` into the longest straight, or
    ``CORNER_BEFORE`` before its end, with ``room_behind`` of the straight behind it for the karts that follow."""
    start, end = longest_straight(track)
    lead_s = start + STRAIGHT_ENTRY if scenario.place == "straight" else end - CORNER_BEFORE
    return max(lead_s, start + room_behind + 1.0) % track.length


def rolling_speed(track: Track, s: float, pace: float) -> float:
    """[m/s] the placed karts' speed: ``ROLLING_FRACTION`` of the racing line's speed at ``s`` at ``pace``."""
    return ROLLING_FRACTION * pace * float(optimise_racing_line(track, PAPER_KART).speed_at(float(s)))


def placements(scenario: Scenario, track: Track, gap: float, leader_pace: float) -> tuple[Placement, Placement]:
    """(leader's, follower's) placement: rolling in the racing lane at the scenario's place, ``gap`` apart."""
    lead_s = lead_progress(scenario, track, gap)
    speed = rolling_speed(track, lead_s, leader_pace)
    lane = racing_lane_at(track, lead_s)
    return Placement(lead_s, lane, speed), Placement(lead_s - gap, lane, speed)  # (behind the line: lap -1)


def inside_lane(track: Track, s: float) -> int:
    """Of the middle lanes, the one on the inside of the first corner after ``s`` (curvature positive: a left
    turn, whose inside is the left lane)."""
    ahead = (s + np.arange(0.0, track.length, CORNER_STEP)) % track.length
    samples = np.minimum(np.searchsorted(track.centre_s, ahead), len(track.centre_s) - 1)
    curvature = track.centre_curvature[samples]
    turning = np.abs(curvature) >= STRAIGHT_CURVATURE
    first = curvature[int(np.argmax(turning))] if turning.any() else 0.0
    return MIDDLE_LANES[0] if first > 0 else MIDDLE_LANES[1]


def side_by_side(
    scenario: Scenario, track: Track, behind: float, pace: float, ego_inside: bool
) -> tuple[Placement, Placement]:
    """(ego's, opponent's) placement: abreast in the middle lanes, rolling toward the corner at the end of the
    longest straight, the ego ``behind`` m behind the opponent (negative: ahead) on the inside or the outside."""
    mid = lead_progress(scenario, track, abs(behind))
    speed = rolling_speed(track, mid, pace)
    inside = inside_lane(track, mid)
    outside = MIDDLE_LANES[1] if inside == MIDDLE_LANES[0] else MIDDLE_LANES[0]
    ego_lane, opponent_lane = (inside, outside) if ego_inside else (outside, inside)
    opponent_s = mid + max(behind, 0.0)
    return Placement(opponent_s - behind, ego_lane, speed), Placement(opponent_s, opponent_lane, speed)


def lapping(
    scenario: Scenario, track: Track, gap: float, rival_gap: float, backmarker_pace: float
) -> tuple[Placement, Placement, Placement]:
    """(ego's, rival's, slower kart's) placement: in the racing lane, the ego ``gap`` behind the slower kart and
    the rival ``rival_gap`` behind the ego, all rolling at the slower kart's speed."""
    slow_s = lead_progress(scenario, track, gap + rival_gap)
    speed = rolling_speed(track, slow_s, backmarker_pace)
    lane = racing_lane_at(track, slow_s)
    return (
        Placement(slow_s - gap, lane, speed),
        Placement(slow_s - gap - rival_gap, lane, speed),
        Placement(slow_s, lane, speed),
    )


def race_laps(scenario: Scenario, track: Track, lead: Placement | None) -> int:
    """The race's laps: it ends at the line, so a placed start in the second half of a lap races one lap more and
    every attempt drives the scenario's laps within half a lap (a grid start: the scenario's laps)."""
    if lead is None:
        return scenario.laps
    return scenario.laps + (1 if lead.progress % track.length > 0.5 * track.length else 0)


def racing_lane_at(track: Track, s: float) -> int:
    """The racing line's lane in the section holding progress ``s`` (lane 2 where it has none)."""
    section = int(np.searchsorted(track.checkpoint_s, s, side="right")) - 1
    lane = track.racing_lanes[section % track.n_checkpoints]
    return int(lane) if lane is not None else 2


def attempt_seed(scenario: str, track: str, attempt: int, seed: int) -> int:
    """Attempt ``attempt``'s seed: the same for every cell of the scenario on the track (paired cells)."""
    digest = [ord(c) for c in f"{scenario}/{track}"]
    return int(np.random.SeedSequence([seed, attempt, *digest]).generate_state(1)[0] % 2**31)


def attempt_specs(scenario: Scenario, cell: Cell, attempts: int, seed: int = 0, first: int = 0) -> list[RaceSpec]:
    """The races of attempts ``first`` to ``first + attempts - 1`` of ``cell`` (the ego is kart 0)."""
    track = load_any_track(cell.track)
    specs = []
    for i in range(first, first + attempts):
        race_seed = attempt_seed(scenario.name, cell.track, i, seed)
        draws = np.random.default_rng([race_seed, 0x6A9])
        gap = float(draws.uniform(*scenario.gap_m))
        controllers, placed, lanes, lead = _attempt_karts(scenario, cell, track, i, gap, draws)
        specs.append(
            RaceSpec(
                track=cell.track,
                controllers=controllers,
                laps=race_laps(scenario, track, lead),
                seed=race_seed,
                conditions=scenario.conditions,
                placements=placed,
                start_lanes=lanes,
            )
        )
    return specs


def _attempt_karts(
    scenario: Scenario, cell: Cell, track: Track, attempt: int, gap: float, draws: np.random.Generator
) -> tuple[tuple[str, ...], tuple[Placement, ...] | None, tuple[int, ...] | None, Placement | None]:
    """(controllers, placements, start lanes, the front kart's placement) of one attempt of ``cell``."""
    ego, opponent = cell.agents(scenario.kind)
    if scenario.kind in ("overtake", "defend"):
        leader_pace = cell.pace if scenario.kind == "overtake" else 1.0
        lead, follow = placements(scenario, track, gap, leader_pace)
        ego_at, opponent_at = (follow, lead) if scenario.kind == "overtake" else (lead, follow)
        return (ego, opponent), (ego_at, opponent_at), None, lead
    if scenario.kind == "side-by-side":
        pair = side_by_side(scenario, track, gap, cell.pace, ego_inside=attempt % 2 == 0)
        return (ego, opponent), pair, None, max(pair, key=lambda p: p.progress)
    if scenario.kind == "lapping":
        rival_gap = float(draws.uniform(*scenario.rival_gap_m))
        trio = lapping(scenario, track, gap, rival_gap, cell.pace)
        backmarker = cell.paced(scenario.backmarker)
        return (ego, opponent, backmarker), trio, None, trio[2]
    lanes = list(DEFAULT_START_LANES[: scenario.karts])
    ego_lane = lanes[attempt % scenario.karts]
    others = [lane for lane in lanes if lane != ego_lane]
    return (ego, *([opponent] * (scenario.karts - 1))), None, (ego_lane, *others), None


@dataclass(frozen=True)
class Attempt:
    """What one attempt gave the ego (kart 0)."""

    success: bool  # see :func:`judge`
    time_to_pass: float | None  # [s] from the start until the ego took the place it then held (overtake, lapping)
    collisions_at_fault: int
    illegal_lane_changes: int
    opponent_collisions_at_fault: int  # of every other kart together
    place: int | None = None  # the ego's place at the end (1: ahead of every kart)


def judge(kind: Kind, outcome: RaceOutcome, first_pass_step: int | None) -> Attempt:
    """The ego's attempt from its race's result; ``first_pass_step``: the step its first pass counted.

    Success: ``overtake``, the ego passed and is ahead of the opponent at the end; ``defend`` and ``side-by-side``,
    it is ahead of the opponent at the end; ``lapping``, it passed the slower kart and is ahead of both at the end;
    ``start``, it leads the field at the end."""
    ego, *others = outcome.result.karts
    opponent = others[0]
    ahead = ego.position < opponent.position
    if kind == "overtake":
        success = ego.passes > 0 and ahead
    elif kind == "lapping":
        slow = others[1]
        success = ego.passes_of[slow.kart] > 0 and ahead and ego.position < slow.position
    elif kind == "start":
        success = ego.position == 1
    else:
        success = ahead
    time_to_pass = None
    if kind in ("overtake", "lapping") and first_pass_step is not None:
        time_to_pass = max(first_pass_step + 1 - PASS_HOLD_STEPS, 0) * DT  # the place was taken 2 s before
    return Attempt(
        success,
        time_to_pass,
        ego.collisions_at_fault,
        ego.illegal_lane_changes,
        sum(k.collisions_at_fault for k in others),
        ego.position,
    )
