"""The telemetry stream of a race: ``/api/races/{id}/telemetry``.

About 25 messages a second: a :class:`~server.models.FrameMessage` ``{"type": "frame", **RaceFrame}`` (race
time, status, every kart with its standing, faults and plan waypoints). When the race ends, the last frame is
followed by a :class:`~server.models.ResultMessage` ``{"type": "result", "race_id", "status", "result"}`` and a
normal close; a race already over gets only that last message, an unknown race a close with 4404.
"""

from __future__ import annotations

import asyncio

from fastapi import APIRouter, WebSocket, WebSocketDisconnect

from server.deps import Races
from server.models import CLOSE_NOT_FOUND, ResultMessage
from server.results import RaceRecord
from server.routes.drive import refuse
from server.status import RaceStatus
from server.ticks import sleep_until
from server.views import result_view

router = APIRouter()


def _result_message(race_id: str, race_status: RaceStatus, result: RaceRecord | None) -> str:
    shown = result_view(result) if result is not None else None
    return ResultMessage(race_id=race_id, status=race_status, result=shown).model_dump_json()


@router.websocket("/races/{race_id}/telemetry")
async def telemetry(websocket: WebSocket, race_id: str, races: Races) -> None:
    """Stream a race's frames (protocol in the module docstring)."""
    await websocket.accept()
    session = races.get(race_id)
    try:
        if session is None:
            stored = await asyncio.to_thread(races.services.db.get, race_id)
            if stored is None:
                return await refuse(websocket, CLOSE_NOT_FOUND, f"no race {race_id}")
            await websocket.send_text(_result_message(race_id, stored.status, stored.result))
            return await websocket.close(code=1000, reason=f"race {stored.status.value}")
        loop = asyncio.get_running_loop()
        interval = 1.0 / races.settings.telemetry_hz
        next_send = loop.time()
        seen = -1
        while True:
            seen = await session.updates.wait(seen)
            message = session.telemetry_message()
            if message is not None:
                await websocket.send_text(message)
            if not session.live:
                await websocket.send_text(_result_message(race_id, session.status, session.result))
                return await websocket.close(code=1000, reason=f"race {session.status.value}")
            next_send = max(next_send + interval, loop.time())
            await sleep_until(next_send)
    except (WebSocketDisconnect, RuntimeError):
        return
