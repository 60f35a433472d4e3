"""Each viewer of a replay has its own playback (web.replay_scene): the clock alone (:class:`Playback`), then
viewers speaking viser's wire protocol as browsers do, on a replay scene's viser server and through the real
race server's relay (``/races/{id}/replay``) of a finished race: one viewer's Play, scrub and speed move nothing
for another, and a viewer that opens the replay later starts paused at the grid."""

from __future__ import annotations

import asyncio
import time
from collections.abc import Iterator
from contextlib import AsyncExitStack
from typing import Any

import msgspec
import pytest
import viser
import websockets
import zstandard
from support.live_server import LiveServer, server_settings, start_race, wait_status
from websockets.typing import Subprotocol

from sim_core.track_io import get_track
from web.frame import KartFrame, RaceFrame
from web.replay_scene import PAUSE, PLAY, Playback, ReplayScene

STEPS = 500  # 10 s at 0.02 s
SUBPROTOCOL = Subprotocol(f"viser-v{viser.__version__}")
CAMERA_MESSAGE = msgspec.msgpack.encode(  # viser counts a client as connected once it reported its camera
    {
        "type": "ViewerCameraMessage",
        "wxyz": [1.0, 0.0, 0.0, 0.0],
        "position": [0.0, -30.0, 30.0],
        "fov": 1.0,
        "near": 0.01,
        "far": 1000.0,
        "image_height": 480,
        "image_width": 640,
        "look_at": [0.0, 0.0, 0.0],
        "up_direction": [0.0, 0.0, 1.0],
    }
)
Message = dict[str, Any]


class StraightLine:
    """Two karts moving 0.1 m along x per step (kart k at y = 3k)."""

    steps = STEPS
    dt = 0.02

    def __init__(self) -> None:
        self.asked: list[int] = []

    def frame(self, step: int, status: str = "replay") -> RaceFrame:
        self.asked.append(step)
        karts = tuple(
            KartFrame(k, f"k{k}", "c", 0.1 * step, 3.0 * k, 0.0, 5.0, 0.0, 0.0, 1, k + 1, 0, 1, 0, 0, 0, False, None, 0)
            for k in range(2)
        )
        return RaceFrame("r", "oval", step * self.dt, step, 1, status, karts, 0)


# ---------------------------------------------------------------------------------------------- the clock
def test_a_playback_runs_at_its_speed_and_stops_at_the_end() -> None:
    playback = Playback(10.0)
    playback.play()
    playback.advance(1.5)
    assert playback.state() == (1.5, True)
    playback.set_speed(4.0)
    playback.advance(0.5)
    assert playback.time == pytest.approx(3.5)
    playback.pause()
    playback.advance(1.0)
    assert playback.state() == (pytest.approx(3.5), False)
    playback.play()
    playback.advance(100.0)
    assert playback.state() == (10.0, False)  # at the end, it stops
    playback.play()  # and plays from the start again
    assert playback.state() == (0.0, True)


# ---------------------------------------------------------------------------------------------- viewers
def decode_frame(data: bytes) -> list[Message]:
    """The messages of one viser websocket frame (``u64 len(msgpack) | u64 len(zstd) | zstd(msgpack) | ...``)."""
    inner_size = int.from_bytes(data[:8], "little")
    compressed_size = int.from_bytes(data[8:16], "little")
    inner = zstandard.ZstdDecompressor().decompress(data[16 : 16 + compressed_size], max_output_size=inner_size)
    return list(msgspec.msgpack.decode(inner)["messages"])


class Viewer:
    """A browser tab of the replay, as viser's client speaks: it reports its camera, keeps every message it gets
    and clicks or sets its panel's elements by label."""

    def __init__(self, ws: websockets.ClientConnection) -> None:
        self.ws = ws
        self.messages: list[Message] = []

    async def receive(self, seconds: float) -> list[Message]:
        """Everything that arrives in the next ``seconds``."""
        got: list[Message] = []
        end = time.monotonic() + seconds
        while (left := end - time.monotonic()) > 0:
            try:
                data = await asyncio.wait_for(self.ws.recv(), left)
            except TimeoutError:
                break
            assert isinstance(data, bytes)
            got += decode_frame(data)
        self.messages += got
        return got

    def element(self, kind: str, label: str) -> str:
        """The uuid of its panel's ``kind`` element labelled ``label``."""
        found = [m["uuid"] for m in self.messages if m["type"] == kind and m["props"]["label"] == label]
        assert found, f"no {kind} {label!r}"
        return str(found[-1])

    async def set(self, kind: str, label: str, value: Any) -> None:
        """Set (a button: click) the element, as the browser does."""
        update = {"type": "GuiUpdateMessage", "uuid": self.element(kind, label), "updates": {"value": value}}
        await self.ws.send(msgspec.msgpack.encode(update))


def kart0_at(messages: list[Message]) -> list[tuple[float, float]]:
    """Every (x, y) the viewer's kart 0 was moved to."""
    moves = [m for m in messages if m["type"] == "SetPositionMessage" and m["name"] == "/karts/kart0"]
    return [(m["position"][0], m["position"][1]) for m in moves]


def kart0_x(messages: list[Message]) -> list[float]:
    """Every x the viewer's kart 0 was moved to."""
    return [x for x, _ in kart0_at(messages)]


@pytest.fixture
def player() -> Iterator[tuple[ReplayScene, StraightLine]]:
    frames = StraightLine()
    scene = ReplayScene(get_track("oval"), [("k0", "c"), ("k1", "c")], "test replay", frames, "/races/r")
    try:
        yield scene, frames
    finally:
        scene.close()


async def open_viewer(scene: ReplayScene | str, stack: Any) -> Viewer:
    """A tab opening the replay (``scene``'s own server, or a websocket URL): connected, with its panel built."""
    url = scene if isinstance(scene, str) else f"ws://127.0.0.1:{scene.port}/"
    ws = await stack.enter_async_context(websockets.connect(url, subprotocols=[SUBPROTOCOL], max_size=None))
    viewer = Viewer(ws)
    await ws.send(CAMERA_MESSAGE)
    deadline = time.monotonic() + 20
    while not any(m["type"] == "GuiSliderMessage" for m in viewer.messages):
        assert time.monotonic() < deadline, "the viewer's panel never came"
        await viewer.receive(0.2)
    await viewer.receive(0.3)  # its grid frame
    return viewer


def test_one_viewers_play_scrub_and_speed_move_nothing_for_another(player: tuple[ReplayScene, StraightLine]) -> None:
    scene, frames = player

    async def run() -> None:
        async with AsyncExitStack() as stack:
            a, b = await open_viewer(scene, stack), await open_viewer(scene, stack)
            assert scene.viewers == 2 and 0 in frames.asked  # each was shown the grid at once
            (id_a, id_b) = sorted(scene.playbacks())
            assert kart0_x(a.messages)[-1] == kart0_x(b.messages)[-1] == 0.0  # the grid of the recording
            assert a.element("GuiButtonMessage", PLAY) != b.element("GuiButtonMessage", PLAY)  # a panel each

            await a.set("GuiButtonMessage", PLAY, True)
            _, seen_by_b = await asyncio.gather(a.receive(0.8), b.receive(0.8))
            playbacks = scene.playbacks()
            assert playbacks[id_a].playing and playbacks[id_a].time > 0.3
            assert not playbacks[id_b].playing and playbacks[id_b].time == 0.0
            moved_a = kart0_x(a.messages)
            assert max(moved_a) > 1.0  # more than 0.2 s of race (10 steps of 0.1 m) shown to a
            assert kart0_x(seen_by_b) == [] and kart0_x(b.messages)[-1] == 0.0  # b's karts stayed on the grid
            assert any(m["type"] == "GuiUpdateMessage" and m["updates"].get("label") == PAUSE for m in a.messages)
            assert not any(m["type"] == "GuiUpdateMessage" and m["updates"].get("label") == PAUSE for m in b.messages)

            # b scrubs to 5 s and plays at 8x; a plays on at 1x from its own moment
            await b.set("GuiSliderMessage", "Time [s]", 5.0)
            await b.set("GuiDropdownMessage", "Speed", "8x")
            await asyncio.gather(a.receive(0.3), b.receive(0.3))
            assert playbacks[id_b].time == 5.0 and playbacks[id_b].speed == 8.0 and playbacks[id_a].speed == 1.0
            assert kart0_x(b.messages)[-1] == pytest.approx(25.0)  # step 250
            assert playbacks[id_a].playing and playbacks[id_a].time < playbacks[id_b].time

            # a tab opening the replay now starts at the grid, paused
            c = await open_viewer(scene, stack)
            (id_c,) = set(scene.playbacks()) - {id_a, id_b}
            assert scene.playbacks()[id_c].state() == (0.0, False) and kart0_x(c.messages)[-1] == 0.0

        deadline = time.monotonic() + 10
        while scene.playbacks():  # the tabs closed: their playbacks go with them
            assert time.monotonic() < deadline, "closed viewers kept their playbacks"
            await asyncio.sleep(0.05)

    asyncio.run(run())


def test_through_the_race_server_each_viewer_plays_its_own_replay(tmp_path_factory: pytest.TempPathFactory) -> None:
    """A finished race's replay watched in two tabs through the server: Play in one moves its karts only; a
    third tab opening the replay then starts at the grid, not where the first one is."""
    db = tmp_path_factory.mktemp("replay-viewers") / "karting.db"
    settings = server_settings(db, viewer_enabled=True, speedup=20.0, keep_finished_s=0.5, controller_hosts=0)
    with LiveServer(settings) as server, server.client() as client:
        race = start_race(client, track="oval", laps=1, seed=1, karts=[{"controller": "lane-follower"}] * 2)
        wait_status(client, race["id"], ("finished",), 120)
        assert client.get(f"/races/{race['id']}/replay/").status_code == 200
        url = f"{server.ws_url}/races/{race['id']}/replay"

        async def run() -> None:
            async with AsyncExitStack() as stack:
                a, b = await open_viewer(url, stack), await open_viewer(url, stack)
                grid = kart0_at(b.messages)[-1]
                assert kart0_at(a.messages)[-1] == grid
                await a.set("GuiButtonMessage", PLAY, True)
                _, seen_by_b = await asyncio.gather(a.receive(1.5), b.receive(1.5))
                assert len(set(kart0_at(a.messages))) > 5 and kart0_at(a.messages)[-1] != grid  # a's karts race
                assert kart0_at(seen_by_b) == []  # b's stay on the grid
                c = await open_viewer(url, stack)  # the replay opened again meanwhile
                assert kart0_at(c.messages)[-1] == grid
                _, seen_by_c = await asyncio.gather(a.receive(0.5), c.receive(0.5))
                assert kart0_at(seen_by_c) == [] and kart0_at(a.messages)[-1] != grid

        asyncio.run(run())
