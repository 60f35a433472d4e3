"""The API's routes under ``/api``: the catalogue (tracks, controllers), races (REST), tournaments (REST), scenario
runs (REST), and the drive and telemetry websockets. :data:`api_router` aggregates them."""

from __future__ import annotations

from fastapi import APIRouter

from server.routes import catalogue, drive, races, scenarios, telemetry, tournaments

api_router = APIRouter(prefix="/api")
for _module in (catalogue, races, drive, telemetry, tournaments, scenarios):
    api_router.include_router(_module.router)
