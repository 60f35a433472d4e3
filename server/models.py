"""Every message at the HTTP and websocket edge, as pydantic models (the OpenAPI schema at ``/docs``).

A kart's result (:class:`KartResultOut`) is derived from the result record (:mod:`server.results`): the
referee's fields of :class:`sim_core.world.KartResult`, whatever this version has, and the driver's faults.
"""

from __future__ import annotations

from dataclasses import fields
from datetime import datetime
from typing import TYPE_CHECKING, Annotated, Any, Literal, get_type_hints

from pydantic import BaseModel, BeforeValidator, ConfigDict, Field, StringConstraints, create_model

from server.drive_events import DRIVE_EVENT_KINDS
from server.limits import (
    MAX_KARTS,
    MAX_LANES,
    MAX_LAPS,
    MAX_NAME_CHARS,
    MAX_NAME_LENGTH,
    MAX_PARAM_TEXT,
    MAX_PARAMS,
    MAX_SEED,
    MIN_KARTS,
    MIN_LAPS,
)
from server.race_config import ParamValue
from server.results import DriverFaults, record_name
from server.status import RaceStatus
from sim_core.conditions import ConditionName
from sim_core.params import MIN_PACE
from sim_core.world import KartResult
from web.frame import KartFrame

CONTROLLER_FAULTS_DOC = (
    "what the kart's controller got wrong: exceptions + hangs + missed deadlines + failed plans + worker restarts "
    "(not collisions: those are collisions_at_fault)"
)
INDEX_DOC = "the kart's grid slot from 0 (pages and the command line show kart numbers from 1: index + 1)"

Name = Annotated[str, StringConstraints(min_length=1, max_length=MAX_NAME_CHARS)]
BoundedParamValue = (
    bool
    | int
    | Annotated[float, Field(allow_inf_nan=False)]
    | Annotated[str, StringConstraints(max_length=MAX_PARAM_TEXT)]
)


def not_a_bool(value: object) -> object:
    """JSON's true and false are not numbers (pydantic's lax mode would read them as 1 and 0)."""
    if isinstance(value, bool):
        raise ValueError("must be a number, not a boolean")
    return value


# a request's numbers: JSON numbers only (2.0 is the integer 2, as JSON Schema has it; true is not 1). Bounds go in
# the field's Field(...); inside a list or an optional field, Annotated[int, Field(...), BeforeValidator(not_a_bool)]
# (bounds first, or the schema loses them)
JsonInt = Annotated[int, BeforeValidator(not_a_bool)]
JsonFloat = Annotated[float, BeforeValidator(not_a_bool)]


class ErrorOut(BaseModel):
    """An error answer: what was wrong."""

    detail: str


class TrackOut(BaseModel):
    """A built-in track."""

    name: str
    length_m: float
    laps: int = Field(description="the track's default number of laps")
    n_checkpoints: int
    n_lanes: int
    lane_change_limit: int = Field(description="L: lanes a kart may cross on one straight")
    description: str


class ControllerOut(BaseModel):
    """A driver a race can name: a registered controller, or ``human``."""

    name: str
    description: str
    parameters: dict[str, str]


class KartIn(BaseModel):
    """One kart of a new race."""

    model_config = ConfigDict(extra="forbid")

    controller: str = Field(min_length=1, max_length=MAX_NAME_CHARS, description="a name from GET /api/controllers")
    name: str | None = Field(
        None,
        min_length=1,
        max_length=MAX_NAME_LENGTH,
        pattern=r"\S",  # not blank (the schema says so too: JSON Schema patterns match anywhere in the string)
        description="display name, not blank and unique in the race, compared without case (default: controller "
        "and kart number, e.g. 'mcts-lqng 1')",
    )
    params: dict[Name, BoundedParamValue] = Field(
        default_factory=dict,
        max_length=MAX_PARAMS,
        description="controller parameters to change (names from GET /api/controllers)",
    )
    pace: JsonFloat = Field(
        1.0,
        ge=MIN_PACE,
        le=1.0,
        description="pace handicap: the kart's speed limits times this and its accelerations times its square, so "
        "that it drives the same line this much slower (1: the race's kart); a human can race a handicapped AI",
    )
    team: str | None = Field(
        None,
        min_length=1,
        max_length=MAX_NAME_LENGTH,
        pattern=r"\S",
        description="the kart's team (karts with the same team name race together: their planners play for the "
        "team); none: the kart races for itself",
    )


class RaceIn(BaseModel):
    """A new race."""

    model_config = ConfigDict(extra="forbid")

    track: str = Field(min_length=1, max_length=MAX_NAME_CHARS, description="a name from GET /api/tracks")
    laps: Annotated[int, Field(ge=MIN_LAPS, le=MAX_LAPS), BeforeValidator(not_a_bool)] | None = Field(
        None, description="default: the track's laps; at most GET /api/limits"
    )
    seed: JsonInt = Field(0, ge=0, le=MAX_SEED, description="seed of the planners")
    start_lanes: list[Annotated[int, Field(ge=1, le=MAX_LANES), BeforeValidator(not_a_bool)]] | None = Field(
        None,
        min_length=1,
        max_length=MAX_KARTS,
        description="one start lane (1-based) per kart, as many as karts; default 2, 3, 1, 4",
    )
    kart_preset: Literal["paper", "original"] = "paper"
    conditions: ConditionName = Field(
        "paper",
        description="race conditions drawn from the seed: paper (every kart launches at once, no imprecision), "
        "varied (launch reactions within 0.25 s, start wear, the AI drivers' small imprecision), varied-pace "
        "(varied, and each AI kart's pace within 2% of the kart's) or varied-equal-distance (varied, and every kart "
        "finishes after the same distance from its own grid slot)",
    )
    karts: list[KartIn] = Field(min_length=MIN_KARTS, max_length=MAX_KARTS)


class LimitsOut(BaseModel):
    """The limits of a race request (the start page's form reads them) and the default kart names."""

    min_laps: int
    max_laps: int
    min_karts: int
    max_karts: int
    max_name_length: int = Field(description="[characters] of a kart's display name")
    max_seed: int
    default_name: str = Field(description="an unnamed kart's name: {controller} and {number} (kart number from 1)")


class KartOut(BaseModel):
    """A kart of a race."""

    index: int = Field(description=INDEX_DOC)
    name: str
    controller: str
    params: dict[str, ParamValue] = Field(default_factory=dict, description="controller parameters changed")
    team: str | None = Field(None, description="its team (none: it races for itself)")


class CreatedKartOut(KartOut):
    """A kart of a just-created race; human karts carry the page to drive them from."""

    drive_url: str | None = None


class RaceCreatedOut(BaseModel):
    """The answer to POST /api/races. The drive tokens are shown only here."""

    id: str
    status: RaceStatus
    track: str
    laps: int
    seed: int
    kart_preset: str
    karts: list[CreatedKartOut]
    viewer_url: str | None = Field(
        description="the live 3D view, which opens while the race starts (None when the server runs without it)"
    )
    telemetry_url: str = Field(description="websocket of RaceFrame messages")
    drive_tokens: dict[str, str] = Field(description="kart index -> token, human karts only")


class StandingOut(BaseModel):
    """One kart's place in the running order."""

    position: int
    index: int = Field(description=INDEX_DOC)
    name: str
    controller: str
    lap: int
    checkpoints_passed: int
    finished: bool
    finish_time: float | None
    controller_faults: int = Field(description=CONTROLLER_FAULTS_DOC)


class TickStatsOut(BaseModel):
    """Tick timing: counts since the start, percentiles over the last 3,000 ticks."""

    period_ms: float
    ticks: int
    overruns: int = Field(description="ticks that started more than one period late")
    skipped: int = Field(description="deadlines skipped after overruns")
    jitter_p50_ms: float = Field(description="|tick start - deadline|")
    jitter_p99_ms: float
    jitter_max_ms: float
    work_p50_ms: float
    work_p99_ms: float


class DriverStatusOut(BaseModel):
    """A kart's driver and its faults."""

    index: int = Field(description=INDEX_DOC)
    name: str
    controller: str
    controller_faults: int = Field(description=CONTROLLER_FAULTS_DOC)
    exceptions: int
    hangs: int
    missed_deadlines: int
    planner_faults: int
    worker_restarts: int = Field(0, description="the process running its controller died and was restarted")
    plans_applied: int
    disabled: bool = Field(description="its controller failed to reset or hung: the kart brakes")
    braking: bool = Field(description="braking for want of fresh input")
    driver_connected: bool | None = Field(description="human karts: a driver is connected")
    last_error: str | None


class RaceSummaryOut(BaseModel):
    """A race in a listing."""

    id: str
    status: RaceStatus
    track: str
    laps: int
    created_at: datetime
    time: float = Field(description="[s] race time")
    karts: list[KartOut]
    standings: list[StandingOut]
    winner: int | None


class RaceDetailOut(RaceSummaryOut):
    """A race in full."""

    seed: int
    kart_preset: str
    start_lanes: list[int] = Field(
        description="each kart's start lane, 1-based, by kart index: as the race asked, else the defaults "
        "(lanes 2, 3, 1, 4 in each row of four)"
    )
    step: int
    drivers: list[DriverStatusOut]
    tick_stats: TickStatsOut | None
    viewer_url: str | None = Field(
        description="the 3D view: the live view while the race is live and its scene is open, the replay player "
        "once it is over (None when the server runs without 3D views, while a live race has no scene open, or when "
        "the race left nothing to replay)"
    )
    page_url: str = Field(description="the race's page (standings, laps, charts, incidents)")
    telemetry_url: str
    result_url: str
    replay_url: str
    report_url: str = Field(description="the figures of the race's page (JSON), once it is over")
    error: str | None


class TicksOut(BaseModel):
    """Tick timing with the raw jitter of the last ticks (for benchmarks)."""

    race_id: str
    stats: TickStatsOut | None
    recent_jitter_ms: list[float]


_REFEREE_DOCS = {
    "finish_time": "[s]",
    "laps": "laps completed",
    "safety_score": "collisions at fault + illegal lane changes (lower is safer)",
    "collisions_at_fault": "collisions the referee blamed on this kart (not controller_faults)",
    "index": INDEX_DOC,
    "delta_r": "[m] mean distance from the planned lane at checkpoints",
    "delta_v": "[m/s] mean difference from the planned speed at checkpoints",
}


def _kart_result_fields() -> dict[str, Any]:
    """``create_model`` fields of a kart's result: identity, the referee's fields (None where a record of an
    older version lacks one), the faults."""
    out: dict[str, Any] = {
        "index": (int, Field(description=INDEX_DOC)),
        "name": (str, ...),
        "controller": (str, ...),
    }
    hints = get_type_hints(KartResult)
    for f in fields(KartResult):
        name = record_name(f.name)
        if name not in out:
            out[name] = (hints[f.name] | None, Field(None, description=_REFEREE_DOCS.get(name)))
    out["lap_times"] = (list[float], Field(default_factory=list, description="[s] each completed lap's time"))
    out["winner"] = (bool, ...)
    hints = get_type_hints(DriverFaults)
    for f in fields(DriverFaults):
        out[f.name] = (hints[f.name], f.default)
    out["controller_faults"] = (int, Field(description=CONTROLLER_FAULTS_DOC))
    return out


if TYPE_CHECKING:

    class KartResultOut(BaseModel):
        """One kart's result (fields derived at run time)."""

else:
    KartResultOut = create_model(
        "KartResultOut",
        __doc__="One kart's result: the referee's figures (the paper's per-race figures) and its controller's faults.",
        **_kart_result_fields(),
    )


class AgentManifestOut(BaseModel):
    """One agent of a manifest: as given, and with every public parameter's value."""

    agent: str = Field(description="as given: NAME or NAME:KEY=VALUE:...")
    name: str = Field(description="the registered controller (or human)")
    full: str = Field(description="the agent string with every public parameter: it builds the same driver")
    parameters: dict[str, bool | int | float | str] = Field(description="every public parameter, defaults included")
    weights: dict[str, str] | None = Field(None, description="the trained weights it loads: path and sha256")


class ManifestOut(BaseModel):
    """What a race or tournament measured (arena.manifest): code, agents, kart, conditions, machine."""

    version: int
    kind: str = Field(description="race or tournament")
    commit: str = Field(description="git commit of the code that ran it, or unknown")
    dirty: bool | None = Field(description="tracked files differed from the commit (None: unknown)")
    agents: list[AgentManifestOut]
    kart_preset: str
    kart: dict[str, Any] = Field(description="the kart preset's values")
    conditions: dict[str, Any] = Field(description="track(s), laps, start lanes, start spread, plan latency, seeds")
    machine: dict[str, Any]


class ResultOut(BaseModel):
    """A race's result (final when ``status`` is ``finished``; the state when stopped otherwise)."""

    race_id: str
    status: RaceStatus
    track: str
    laps: int
    seed: int | None = Field(None, description="seed of the planners (None: a result stored before it was kept)")
    kart_preset: str | None = None
    start_lanes: list[int] | None = Field(None, description="each kart's start lane, 1-based, by kart index")
    duration: float = Field(description="[s] race time (times are rounded to the millisecond)")
    winner: int | None = Field(description="index of the fastest finisher's kart; None if nobody finished")
    karts: list[KartResultOut]
    end_reason: str | None = Field(None, description="why the race ended (absent in results of older versions)")
    manifest: ManifestOut | None = Field(None, description="what the race measured (None in older results)")


class DriveInput(BaseModel):
    """A message on the drive websocket: the kart's inputs until the next message."""

    model_config = ConfigDict(extra="forbid")

    steer: float = Field(ge=-1.0, le=1.0, allow_inf_nan=False, description="positive = left")
    throttle: float = Field(ge=-1.0, le=1.0, allow_inf_nan=False, description="negative brakes")
    seq: int | None = Field(
        None, ge=0, le=2**53, description="echoed back as input_seq in the state after it is applied"
    )


class DriveReady(BaseModel):
    """A message on the drive websocket: the driver's view has loaded (clients that connect with ``view=1``)."""

    model_config = ConfigDict(extra="forbid")

    type: Literal["ready"]


# ----------------------------------------------------------------------------------------- websocket messages
# close codes of refused or ended websocket connections (1000: a normal close at the end of a race)
CLOSE_BAD_REQUEST = 4400
CLOSE_FORBIDDEN = 4403
CLOSE_NOT_FOUND = 4404
CLOSE_TAKEN = 4409
CLOSE_OVER = 4410
CLOSE_TOO_BIG = 1009  # RFC 6455 "message too big": over the socket's limit (server.routes.sockets)


class StateMessage(BaseModel):
    """Drive websocket, after every tick: the driven kart and the input ``seq`` that tick applied."""

    type: Literal["state"] = "state"
    step: int
    time: float
    status: str
    input_seq: int | None
    braking: bool
    kart: KartFrame
    countdown: float | None = Field(None, description="[s] left before the start (status countdown)")
    waiting_for: list[str] = Field(
        default_factory=list, description="status waiting: the human drivers not yet connected or not yet ready"
    )


class EventMessage(BaseModel):
    """Drive websocket: something that just happened to the driven kart, worded for its driver's screen."""

    type: Literal["event"] = "event"
    kind: str = Field(description="one of " + ", ".join(DRIVE_EVENT_KINDS))
    text: str
    time: float = Field(description="[s] race time")


class EndMessage(BaseModel):
    """Drive websocket, once the race is over (then a normal close)."""

    type: Literal["end"] = "end"
    status: RaceStatus
    result: ResultOut | None


class ErrorMessage(BaseModel):
    """Drive websocket: what was wrong with the last message (the connection stays)."""

    type: Literal["error"] = "error"
    error: str


class FrameMessage(BaseModel):
    """Telemetry websocket, about 25 a second: a :class:`web.frame.RaceFrame` with its ``type``."""

    type: Literal["frame"] = "frame"
    race_id: str
    track: str
    time: float
    step: int
    laps: int
    status: str
    karts: tuple[KartFrame, ...]
    plans_version: int
    countdown: float | None = Field(None, description="[s] left before the start (status countdown)")


class ResultMessage(BaseModel):
    """Telemetry websocket, once the race is over (then a normal close)."""

    type: Literal["result"] = "result"
    race_id: str
    status: RaceStatus
    result: ResultOut | None
