"""The race server: FastAPI app (:mod:`server.app`), races stepped at 50 Hz (:mod:`server.session`), their
drivers (:mod:`server.drivers`, :mod:`server.hosts`), planner workers (:mod:`server.planning`), the REST API
and websockets (:mod:`server.api`, :mod:`server.ws`, messages in :mod:`server.models`), storage
(:mod:`server.db`) and settings (:mod:`server.settings`)."""
