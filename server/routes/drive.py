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
close with a code and reason: 4400 bad ``kart`` or ``view`` / not a human kart, 4403 wrong token, 4404 no such
race, 4409 the kart already has a driver, 4410 the race is over.
"""

from __future__ import annotations

import asyncio
import contextlib
import secrets

from fastapi import APIRouter, WebSocket, WebSocketDisconnect
from pydantic import ValidationError

from server.deps import Races
from server.drive_events import DriveEvents
from server.drivers import KartDriver
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
from server.session import RaceSession
from server.views import result_view

MAX_MESSAGE_CHARS = 1000  # drive messages are tiny; anything longer is refused

router = APIRouter()


async def refuse(websocket: WebSocket, code: int, reason: str) -> None:
    """Close an accepted websocket with ``code`` and ``reason``."""
    await websocket.close(code=code, reason=reason)


def _describe(exc: ValidationError) -> str:
    parts = []
    for error in exc.errors():
        where = ".".join(str(p) for p in error["loc"]) or "message"
        parts.append(f"{where}: {error['msg']}")
    return "; ".join(parts)


def _parse(text: str) -> DriveInput | DriveReady | str:
    """The input or the ready message in ``text``, or what is wrong with it."""
    if len(text) > MAX_MESSAGE_CHARS:
        return f"message too long ({len(text)} characters, at most {MAX_MESSAGE_CHARS})"
    try:
        return DriveInput.model_validate_json(text)
    except ValidationError as exc:
        error = exc
    if '"type"' in text:  # inputs have no type: say what is wrong with it as a ready message
        try:
            return DriveReady.model_validate_json(text)
        except ValidationError as exc:
            error = exc
    return _describe(error)


@router.websocket("/races/{race_id}/drive")
async def drive(websocket: WebSocket, race_id: str, races: Races) -> None:
    """Drive a human kart (protocol in the module docstring)."""
    await websocket.accept()
    kart_param = websocket.query_params.get("kart")
    token = websocket.query_params.get("token", "")
    view = websocket.query_params.get("view", "0")
    session = races.get(race_id)
    if session is None:
        stored = await asyncio.to_thread(races.services.db.get, race_id)
        if stored is None:
            return await refuse(websocket, CLOSE_NOT_FOUND, f"no race {race_id}")
        return await refuse(websocket, CLOSE_OVER, f"race is over ({stored.status.value})")
    if kart_param is None or not kart_param.isdigit() or int(kart_param) >= len(session.drivers):
        return await refuse(websocket, CLOSE_BAD_REQUEST, f"kart must be 0..{len(session.drivers) - 1}")
    if view not in ("0", "1"):
        return await refuse(websocket, CLOSE_BAD_REQUEST, "view must be 0 or 1")
    driver = session.drivers[int(kart_param)]
    if not driver.human or driver.token is None:
        return await refuse(websocket, CLOSE_BAD_REQUEST, f"kart {driver.index} is not a human kart")
    if not secrets.compare_digest(token.encode(), driver.token.encode()):
        return await refuse(websocket, CLOSE_FORBIDDEN, "wrong token")
    if not session.live:
        return await refuse(websocket, CLOSE_OVER, f"race is over ({session.status.value})")
    if driver.connected:
        return await refuse(websocket, CLOSE_TAKEN, f"kart {driver.index} already has a driver")
    driver.connected = True
    driver.ever_connected = True
    driver.view_ready = view == "0"
    lock = asyncio.Lock()  # the state sender and the error replies share the socket
    sender = asyncio.get_running_loop().create_task(_send_states(websocket, session, driver, lock))
    try:
        while True:
            message = await websocket.receive()
            if message["type"] == "websocket.disconnect":
                break
            text = message.get("text")
            if text is None:
                text = (message.get("bytes") or b"").decode("utf-8", errors="replace")
            parsed = _parse(text)
            if isinstance(parsed, str):
                async with lock:
                    await websocket.send_text(ErrorMessage(error=parsed).model_dump_json())
                continue
            if isinstance(parsed, DriveReady):
                driver.view_ready = True
            else:
                session.drive_input(driver.index, parsed.steer, parsed.throttle, parsed.seq)
    except (WebSocketDisconnect, RuntimeError):
        pass  # the sender closed the socket at the end of the race, or the client went away
    finally:
        driver.connected = False
        sender.cancel()
        with contextlib.suppress(asyncio.CancelledError):
            await sender


async def _send_states(websocket: WebSocket, session: RaceSession, driver: KartDriver, lock: asyncio.Lock) -> None:
    events = DriveEvents(session.config.track, driver.index)
    seen = -1
    try:
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
                async with lock:
                    await websocket.send_text(state.model_dump_json())
                    for event in happened:
                        await websocket.send_text(event.model_dump_json())
            if not session.live:
                result = result_view(session.result) if session.result is not None else None
                async with lock:
                    await websocket.send_text(EndMessage(status=session.status, result=result).model_dump_json())
                    await websocket.close(code=1000, reason=f"race {session.status.value}")
                return
    except (WebSocketDisconnect, RuntimeError):
        return
