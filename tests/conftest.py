"""Shared test configuration: deterministic hypothesis runs (no deadline: the first call of a compiled kernel
includes its compilation)."""

from __future__ import annotations

from hypothesis import settings

settings.register_profile("project", deadline=None, derandomize=True, print_blob=True)
settings.load_profile("project")
