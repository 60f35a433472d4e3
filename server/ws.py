"""Websockets: driving a human kart, and the telemetry stream of a race.

``/api/races/{id}/drive?kart=K&token=T``
    The client sends ``{"steer": s, "throttle": t}`` (each in [-1, 1], optionally ``"seq": n``) up to 50 times
    a second; the newest message holds until the next. After every tick the server sends
    ``{"type": "state", "step", "time", "status", "input_seq", "braking", "kart": {KartFrame}}``, where
    ``input_seq`` is the ``seq`` of the input that tick applied. A bad message gets ``{"type": "error",
    "error": ...}`` and the connection stays. Silence for ``drive_timeout_s`` brakes the kart. When the race
    ends: ``{"type": "end", "status", "result"}`` and a normal close. Refusals close with a code and reason:
    4400 bad ``kart`` / not a human kart, 4403 wrong token, 4404 no such race, 4409 the kart already has a
    driver, 4410 the race is over.

``/api/races/{id}/telemetry``
    About 25 messages a second: ``{"type": "frame", **dataclasses.asdict(RaceFrame)}`` (race time, status,
    every kart with its standing, faults and plan waypoints). When the race ends, the last frame is followed by
    ``{"type": "result", "race_id", "status", "result"}`` and a normal close; a race already over gets only
    that last message.
"""

from __future__ import annotations

import asyncio
import contextlib
import json
import secrets
from typing import Any

from fastapi import APIRouter, WebSocket, WebSocketDisconnect
from pydantic import ValidationError

from server.api import Races
from server.drivers import KartDriver
from server.models import DriveInput, ResultOut
from server.session import RaceSession
from server.ticks import sleep_until

CLOSE_BAD_REQUEST = 4400
CLOSE_FORBIDDEN = 4403
CLOSE_NOT_FOUND = 4404
CLOSE_TAKEN = 4409
CLOSE_OVER = 4410
MAX_MESSAGE_CHARS = 1000  # drive messages are tiny; anything longer is refused

router = APIRouter(prefix="/api")


async def _refuse(websocket: WebSocket, code: int, reason: str) -> None:
    await websocket.close(code=code, reason=reason)


def _describe(exc: ValidationError) -> str:
    parts = []
    for error in exc.errors():
        where = ".".join(str(p) for p in error["loc"]) or "message"
        parts.append(f"{where}: {error['msg']}")
    return "; ".join(parts)


def _parse(text: str) -> DriveInput | str:
    """The input in ``text``, or what is wrong with it."""
    if len(text) > MAX_MESSAGE_CHARS:
        return f"message too long ({len(text)} characters, at most {MAX_MESSAGE_CHARS})"
    try:
        return DriveInput.model_validate_json(text)
    except ValidationError as exc:
        return _describe(exc)


@router.websocket("/races/{race_id}/drive")
async def drive(websocket: WebSocket, race_id: str, races: Races) -> None:
    """Drive a human kart (protocol in the module docstring)."""
    await websocket.accept()
    kart_param = websocket.query_params.get("kart")
    token = websocket.query_params.get("token", "")
    session = races.get(race_id)
    if session is None:
        stored = await asyncio.to_thread(races.db.get, race_id)
        if stored is None:
            return await _refuse(websocket, CLOSE_NOT_FOUND, f"no race {race_id}")
        return await _refuse(websocket, CLOSE_OVER, f"race is over ({stored.status})")
    if kart_param is None or not kart_param.isdigit() or int(kart_param) >= len(session.drivers):
        return await _refuse(websocket, CLOSE_BAD_REQUEST, f"kart must be 0..{len(session.drivers) - 1}")
    driver = session.drivers[int(kart_param)]
    if not driver.human or driver.token is None:
        return await _refuse(websocket, CLOSE_BAD_REQUEST, f"kart {driver.index} is not a human kart")
    if not secrets.compare_digest(token.encode(), driver.token.encode()):
        return await _refuse(websocket, CLOSE_FORBIDDEN, "wrong token")
    if not session.live:
        return await _refuse(websocket, CLOSE_OVER, f"race is over ({session.status})")
    if driver.connected:
        return await _refuse(websocket, CLOSE_TAKEN, f"kart {driver.index} already has a driver")
    driver.connected = True
    driver.ever_connected = True
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
                    await websocket.send_text(json.dumps({"type": "error", "error": parsed}))
                continue
            session.drive_input(driver.index, parsed.steer, parsed.throttle, parsed.seq)
    except (WebSocketDisconnect, RuntimeError):
        pass  # the sender closed the socket at the end of the race, or the client went away
    finally:
        driver.connected = False
        sender.cancel()
        with contextlib.suppress(asyncio.CancelledError):
            await sender


async def _send_states(websocket: WebSocket, session: RaceSession, driver: KartDriver, lock: asyncio.Lock) -> None:
    seen = -1
    try:
        while True:
            seen = await session.updates.wait(seen)
            frame = session.frame
            if frame is not None:
                state = {
                    "type": "state",
                    "step": frame.step,
                    "time": frame.time,
                    "status": frame.status,
                    "input_seq": driver.applied_seq,
                    "braking": driver.braking,
                    "kart": frame.karts[driver.index].__dict__,  # a flat dataclass: its fields
                }
                async with lock:
                    await websocket.send_text(json.dumps(state))
            if not session.live:
                async with lock:
                    await websocket.send_text(
                        json.dumps({"type": "end", "status": session.status, "result": _public(session.result)})
                    )
                    await websocket.close(code=1000, reason=f"race {session.status}")
                return
    except (WebSocketDisconnect, RuntimeError):
        return


def _public(result: dict[str, Any] | None) -> dict[str, Any] | None:
    """A stored result as GET /api/races/{id}/result shows it."""
    return ResultOut.model_validate(result).model_dump(mode="json") if result is not None else None


def _result_message(race_id: str, race_status: str, result: dict[str, Any] | None) -> str:
    return json.dumps({"type": "result", "race_id": race_id, "status": race_status, "result": _public(result)})


@router.websocket("/races/{race_id}/telemetry")
async def telemetry(websocket: WebSocket, race_id: str, races: Races) -> None:
    """Stream a race's frames (protocol in the module docstring)."""
    await websocket.accept()
    session = races.get(race_id)
    try:
        if session is None:
            stored = await asyncio.to_thread(races.db.get, race_id)
            if stored is None:
                return await _refuse(websocket, CLOSE_NOT_FOUND, f"no race {race_id}")
            await websocket.send_text(_result_message(race_id, stored.status, stored.result))
            return await websocket.close(code=1000, reason=f"race {stored.status}")
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
                return await websocket.close(code=1000, reason=f"race {session.status}")
            next_send = max(next_send + interval, loop.time())
            await sleep_until(next_send)
    except (WebSocketDisconnect, RuntimeError):
        return
