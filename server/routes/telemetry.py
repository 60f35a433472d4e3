"""The telemetry stream of a race: ``/api/races/{id}/telemetry``.

About 25 messages a second: a :class:`~server.models.FrameMessage` ``{"type": "frame", **RaceFrame}`` (race
time, status, every kart with its standing, faults and plan waypoints). When the race ends, the last frame is
followed by a :class:`~server.models.ResultMessage` ``{"type": "result", "race_id", "status", "result"}`` and a
normal close; a race already over gets only that last message, an unknown race a close with 4404, a malformed
race id 4400. The socket is read-only: what a client sends is read and dropped, and a message over 1 KiB closes
it with 1009 (:mod:`server.routes.sockets`).
"""

from __future__ import annotations

import asyncio

from fastapi import APIRouter, WebSocket

from server.deps import Races
from server.live import LiveRaces
from server.models import CLOSE_NOT_FOUND, ResultMessage
from server.results import RaceRecord
from server.routes.sockets import RefusedError, SocketWriter, TelemetryParams, refuse, serve_socket, socket_params
from server.session import RaceSession
from server.status import RaceStatus
from server.ticks import sleep_until
from server.views import result_view

MAX_MESSAGE_BYTES = 1024  # [bytes] the socket is read-only: small messages are dropped, bigger ones close it

router = APIRouter()


def _result_message(race_id: str, race_status: RaceStatus, result: RaceRecord | None) -> str:
    shown = result_view(result) if result is not None else None
    return ResultMessage(race_id=race_id, status=race_status, result=shown).model_dump_json()


@router.websocket("/races/{race_id}/telemetry")
async def telemetry(websocket: WebSocket, race_id: str, races: Races) -> None:
    """Stream a race's frames (protocol in the module docstring)."""
    await websocket.accept()
    writer = SocketWriter(websocket)
    try:
        params = socket_params(TelemetryParams, websocket, {"race_id": race_id})
    except RefusedError as refusal:
        return await refuse(websocket, refusal.code, refusal.reason)
    session = races.get(params.race_id)
    sending = _send_frames(writer, session, races) if session is not None else _send_stored(writer, race_id, races)
    await serve_socket(writer, sending, max_message_bytes=MAX_MESSAGE_BYTES)


async def _send_stored(writer: SocketWriter, race_id: str, races: LiveRaces) -> None:
    stored = await asyncio.to_thread(races.services.db.get, race_id)
    if stored is None:
        return await writer.close(CLOSE_NOT_FOUND, f"no race {race_id}")
    await writer.send_text(_result_message(race_id, stored.status, stored.result))
    await writer.close(1000, f"race {stored.status.value}")


async def _send_frames(writer: SocketWriter, session: RaceSession, races: LiveRaces) -> None:
    loop = asyncio.get_running_loop()
    interval = 1.0 / races.settings.telemetry_hz
    next_send = loop.time()
    seen = -1
    while not writer.closed:
        seen = await session.updates.wait(seen)
        message = session.telemetry_message()
        if message is not None:
            await writer.send_text(message)
        if not session.live:
            await writer.send_text(_result_message(session.id, session.status, session.result))
            return await writer.close(1000, f"race {session.status.value}")
        next_send = max(next_send + interval, loop.time())
        await sleep_until(next_send)
