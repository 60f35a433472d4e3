"""A setting is named once: ``Settings.env_name`` gives the environment variable that sets a field (what pages,
messages and documents cite), and that variable does set it (the human drivers' wait, as the example)."""

from __future__ import annotations

import pytest

from server.settings import Settings


def test_a_fields_environment_variable_sets_it(monkeypatch: pytest.MonkeyPatch) -> None:
    name = Settings.env_name("human_wait_s")
    assert name == "KARTING_HUMAN_WAIT_S"
    default = Settings().human_wait_s
    monkeypatch.setenv(name, str(default + 30.0))
    assert Settings().human_wait_s == default + 30.0


def test_an_unknown_field_has_no_name() -> None:
    with pytest.raises(KeyError):
        Settings.env_name("human_wait")
