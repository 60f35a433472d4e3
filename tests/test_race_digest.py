"""The race digest: every registered agent's first seconds on oval and complex, from both start lanes, hashed at
every simulation step against the stored golden file (``scripts/race_digest.py --write`` regenerates it after a
deliberate behaviour change)."""

from __future__ import annotations

import json

import pytest

from scripts.race_digest import GOLDEN, race_hash, race_names

STORED: dict[str, str] = json.loads(GOLDEN.read_text())


def test_the_golden_file_covers_every_digest_race() -> None:
    assert sorted(STORED) == sorted(race_names())


@pytest.mark.parametrize("name", race_names())
def test_race_is_bit_identical_to_the_stored_digest(name: str) -> None:
    assert race_hash(name) == STORED[name], f"{name} changed: regenerate only for a deliberate behaviour change"
