"""Driving a human kart over a websocket: ``/api/races/{id}/drive?kart=K&token=T`` (optionally ``&view=1``).

The client sends ``{"steer": s, "throttle": t}`` (each in [-1, 1], optionally ``"seq": n``) up to 50 times a
second; the newest message holds until the next. A race with human karts starts once every driver is connected
and ready, after a countdown (status ``countdown``) during which no kart moves. A client is ready when it
connects, unless it connects with ``view=1``: a client that first loads a view of the race (the drive page), and
then says ``{"type": "ready"}``. After every tick (and ten times a second before the start) the server sends a
:class:`~server.models.StateMessage` ``{"type": "state", "step", "time", "status", "input_seq", "braking",
"kart": {KartFrame}, "countdown", "waiting_for"}``, where ``input_seq`` is the ``seq`` of the input that tick
applied, ``countdown`` the seconds left before the start and ``waiting_for`` the drivers the race still waits for;
and an :class:`~server.models.EventMessage` ``{"type": "event", "kind", "text", "time"}`` when something happens
to the kart (:mod:`server.drive_events`: the start, wall hits, collisions at fault, illegal lane changes, driving
the wrong way, passes, laps, the finish). A bad message gets an :class:`~server.models.ErrorMessage` ``{"type":
"error", "error": ...}`` and the connection stays. Silence for ``drive_timeout_s`` brakes the kart. When the race
ends: an :class:`~server.models.EndMessage` ``{"type": "end", "status", "result"}`` and a normal close. Refusals
close with a code and reason: 4400 bad ``kart`` or ``view`` / not a human kart, or any other malformed parameter
(:mod:`server.routes.sockets`), 4403 wrong token, 4404 no such race, 4409 the kart already has a driver, 4410 the
race is over; a message over 4 KiB closes with 1009.
"""

from __future__ import annotations

import asyncio
import secrets

from fastapi import APIRouter, WebSocket
from pydantic import ValidationError

from server.deps import Races
from server.drive_events import DriveEvents
from server.drivers import KartDriver
from server.live import LiveRaces
from server.models import (
    CLOSE_BAD_REQUEST,
    CLOSE_FORBIDDEN,
    CLOSE_NOT_FOUND,
    CLOSE_OVER,
    CLOSE_TAKEN,
    DriveInput,
    DriveReady,
    EndMessage,
    ErrorMessage,
    EventMessage,
    StateMessage,
)
from server.routes.sockets import DriveParams, RefusedError, SocketWriter, describe, refuse, serve_socket, socket_params
from server.session import RaceSession
from server.views import result_view

MAX_MESSAGE_BYTES = 4096  # [bytes] a drive message is about 60; a longer one closes the socket with 1009

router = APIRouter()


def _parse(text: str) -> DriveInput | DriveReady | str:
    """The input or the ready message in ``text``, or what is wrong with it."""
    try:
        return DriveInput.model_validate_json(text)
    except ValidationError as exc:
        error = exc
    if '"type"' in text:  # inputs have no type: say what is wrong with it as a ready message
        try:
            return DriveReady.model_validate_json(text)
        except ValidationError as exc:
            error = exc
    return describe(error)


async def _claim(websocket: WebSocket, race_id: str, races: LiveRaces) -> tuple[RaceSession, KartDriver, DriveParams]:
    """The race and the kart this connection may drive, and its parameters; raises :class:`RefusedError` with why
    not."""
    params = socket_params(DriveParams, websocket, {"race_id": race_id})
    session = races.get(params.race_id)
    if session is None:
        stored = await asyncio.to_thread(races.services.db.get, params.race_id)
        if stored is None:
            raise RefusedError(CLOSE_NOT_FOUND, f"no race {params.race_id}")
        raise RefusedError(CLOSE_OVER, f"race is over ({stored.status.value})")
    if params.kart >= len(session.drivers):
        raise RefusedError(CLOSE_BAD_REQUEST, f"kart must be 0..{len(session.drivers) - 1}")
    driver = session.drivers[params.kart]
    if not driver.human or driver.token is None:
        raise RefusedError(CLOSE_BAD_REQUEST, f"kart {driver.index} is not a human kart")
    if not secrets.compare_digest(params.token.encode(), driver.token.encode()):
        raise RefusedError(CLOSE_FORBIDDEN, "wrong token")
    if not session.live:
        raise RefusedError(CLOSE_OVER, f"race is over ({session.status.value})")
    if driver.connected:
        raise RefusedError(CLOSE_TAKEN, f"kart {driver.index} already has a driver")
    return session, driver, params


@router.websocket("/races/{race_id}/drive")
async def drive(websocket: WebSocket, race_id: str, races: Races) -> None:
    """Drive a human kart (protocol in the module docstring)."""
    await websocket.accept()
    try:
        session, driver, params = await _claim(websocket, race_id, races)
    except RefusedError as refusal:
        return await refuse(websocket, refusal.code, refusal.reason)
    driver.connected = True
    driver.ever_connected = True
    driver.view_ready = params.view == 0
    writer = SocketWriter(websocket)

    async def on_message(text: str) -> None:
        parsed = _parse(text)
        if isinstance(parsed, str):
            await writer.send_text(ErrorMessage(error=parsed).model_dump_json())
        elif isinstance(parsed, DriveReady):
            driver.view_ready = True
        else:
            session.drive_input(driver.index, parsed.steer, parsed.throttle, parsed.seq)

    try:
        sending = _send_states(writer, session, driver)
        await serve_socket(writer, sending, max_message_bytes=MAX_MESSAGE_BYTES, on_message=on_message)
    finally:
        driver.connected = False


async def _send_states(writer: SocketWriter, session: RaceSession, driver: KartDriver) -> None:
    events = DriveEvents(session.config.track, driver.index)
    seen = -1
    while True:
        seen = await session.updates.wait(seen)
        frame = session.frame
        if frame is not None:
            state = StateMessage(
                step=frame.step,
                time=frame.time,
                status=frame.status,
                input_seq=driver.applied_seq,
                braking=driver.braking,
                kart=frame.karts[driver.index],
                countdown=frame.countdown,
                waiting_for=[d.name for d in session.waiting_for()],
            )
            happened = [EventMessage(kind=e.kind, text=e.text, time=e.time) for e in events.update(frame)]
            await writer.send_text(state.model_dump_json())
            for event in happened:
                await writer.send_text(event.model_dump_json())
        if not session.live:
            result = result_view(session.result) if session.result is not None else None
            await writer.send_text(EndMessage(status=session.status, result=result).model_dump_json())
            await writer.close(1000, f"race {session.status.value}")
            return
