"""The race server: FastAPI app (:mod:`server.app`), races stepped at 50 Hz (:mod:`server.session`, their frames
and replays in :mod:`server.frames`, their results in :mod:`server.results`), their drivers
(:mod:`server.drivers`, :mod:`server.hosts`), planner workers (:mod:`server.planning`,
:mod:`server.plan_requests`), the REST API and websockets (:mod:`server.routes`, answers built in
:mod:`server.views`, messages in :mod:`server.models` and, to worker processes, :mod:`server.host_messages`),
storage (:mod:`server.db`) and settings (:mod:`server.settings`)."""

from sim_core import _numeric_target  # noqa: F401  (one x86-64 level for every library: before numpy is imported)
