"""What each tick leaves behind: the :class:`~web.frame.RaceFrame` that viewers and telemetry show, its telemetry
message, and the replay's row (every kart's pose and inputs, and the plans as they were applied).
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

from controllers.replay import Replay
from server.drivers import KartDriver
from server.models import FrameMessage
from server.race_config import KartEntry
from sim_core import state as st
from sim_core.params import DT
from sim_core.world import World
from web.frame import KartFrame, RaceFrame

POSE_COLUMNS = [st.F_X, st.F_Y, st.F_HEADING, st.F_SPEED]


def build_frame(
    race_id: str,
    track_name: str,
    laps: int,
    status: str,
    world: World,
    drivers: Sequence[KartDriver],
    plans: int,
    countdown: float | None = None,
) -> RaceFrame:
    """The frame of race 0 of ``world`` now, with each kart's driver (faults, drawn plan: none once the kart
    finished); ``plans`` is the race's plans version, ``countdown`` [s] the time left before the start."""
    n_cp = world.track.n_checkpoints
    fs = world.fstate[0].tolist()
    ints = world.istate[0].tolist()
    position = [0] * len(drivers)
    for place, k in enumerate(world.standings(0)):
        position[k] = place + 1
    karts = []
    for d in drivers:
        f, i = fs[d.index], ints[d.index]
        finished = bool(i[st.I_FINISHED])
        karts.append(
            KartFrame(
                index=d.index,
                name=d.name,
                controller=d.controller_name,
                x=f[st.F_X],
                y=f[st.F_Y],
                heading=f[st.F_HEADING],
                speed=f[st.F_SPEED],
                steer=f[st.F_STEER],
                throttle=f[st.F_THROTTLE],
                lap=min(max(i[st.I_CP_PASSED], 0) // n_cp + 1, laps),
                position=position[d.index],
                checkpoints_passed=i[st.I_CP_PASSED],
                lane=i[st.I_LANE],
                collisions_at_fault=i[st.I_FAULTS],
                illegal_lane_changes=i[st.I_ILLEGAL],
                wall_hits=i[st.I_WALL_HITS],
                finished=finished,
                finish_time=f[st.F_FINISH_TIME] if finished else None,
                controller_faults=d.faults,
                waypoints=() if finished else d.waypoints,
                predicted=() if finished else d.predicted,
                team=d.entry.team,
            )
        )
    step = int(world.steps[0])
    return RaceFrame(
        race_id=race_id,
        track=track_name,
        time=step * DT,
        step=step,
        laps=laps,
        status=status,
        karts=tuple(karts),
        plans_version=plans,
        countdown=countdown,
    )


class TelemetryMessage:
    """The telemetry JSON of the newest frame, built once per frame however many subscribers read it."""

    def __init__(self) -> None:
        self._frame: RaceFrame | None = None
        self._text = ""

    def of(self, frame: RaceFrame) -> str:
        """``frame`` as a :class:`~server.models.FrameMessage` (JSON)."""
        if frame is not self._frame:
            self._text = FrameMessage(**frame.__dict__).model_dump_json()
            self._frame = frame
        return self._text


def replay_json(replay: Replay, race_id: str, karts: Sequence[KartEntry]) -> dict[str, Any]:
    """A race's replay (the headless format, :class:`controllers.replay.Replay`) plus the race id and karts."""
    listed = [{"index": k.index, "name": k.name, "controller": k.controller} for k in karts]
    return {"race_id": race_id, "karts": listed, **vars(replay)}
