"""What a race can be made of: ``GET /api/tracks``, ``GET /api/controllers`` and ``GET /api/limits``."""

from __future__ import annotations

import asyncio
from functools import lru_cache

from fastapi import APIRouter

from server.deps import Races
from server.limits import DEFAULT_NAME, MAX_KARTS, MAX_NAME_LENGTH, MAX_SEED, MIN_KARTS, MIN_LAPS
from server.models import ControllerOut, LimitsOut, TrackOut
from server.race_config import HUMAN
from sim_core.track import Track
from sim_core.track_io import builtin_track_names, get_track

HUMAN_DESCRIPTION = "A person (or a client program) driving over the websocket /api/races/{id}/drive."

router = APIRouter()


def track_names() -> list[str]:
    """Every built-in track, each also driven the other way."""
    names = builtin_track_names()
    return [*names, *(f"{name}-reversed" for name in names)]


@lru_cache(maxsize=32)
def load_track(name: str) -> Track:
    """A built-in track by name (cached: tracks are never changed)."""
    return get_track(name)


@router.get("/tracks", response_model=list[TrackOut])
async def list_tracks() -> list[TrackOut]:
    """The built-in tracks (each also as ``NAME-reversed``)."""
    tracks = await asyncio.to_thread(lambda: [load_track(n) for n in track_names()])
    return [
        TrackOut(
            name=t.name,
            length_m=round(t.length, 1),
            laps=t.laps,
            n_checkpoints=t.n_checkpoints,
            n_lanes=t.n_lanes,
            lane_change_limit=t.lane_change_limit,
            description=t.description,
        )
        for t in tracks
    ]


@router.get("/controllers", response_model=list[ControllerOut])
async def list_controllers(races: Races) -> list[ControllerOut]:
    """Every registered controller, plus ``human``."""
    catalogue = races.services.catalogue
    specs = [catalogue[name] for name in sorted(catalogue)]
    out = [ControllerOut(name=s.name, description=s.description, parameters=dict(s.parameters)) for s in specs]
    return [*out, ControllerOut(name=HUMAN, description=HUMAN_DESCRIPTION, parameters={})]


@router.get("/limits", response_model=LimitsOut)
async def race_limits(races: Races) -> LimitsOut:
    """The limits of a race request (laps, karts, name length, seed) and the default kart names: the start page's
    form takes them from here, so it allows what the API allows."""
    return LimitsOut(
        min_laps=MIN_LAPS,
        max_laps=races.settings.max_laps,
        min_karts=MIN_KARTS,
        max_karts=MAX_KARTS,
        max_name_length=MAX_NAME_LENGTH,
        max_seed=MAX_SEED,
        default_name=DEFAULT_NAME,
    )
