"""The limits of a race request, defined once: the API's models check them, and the start page's form reads
them from ``GET /api/limits`` (with the default kart names), so the two cannot disagree.

The most laps a race may have is a server setting (``Settings.max_laps``, ``KARTING_MAX_LAPS``).
"""

from __future__ import annotations

MIN_KARTS = 1
MAX_KARTS = 8  # one colour per grid slot (web.frame.KART_COLORS)
MAX_NAME_LENGTH = 32  # [characters] of a kart's display name: it must fit the viewer's standings table
MIN_LAPS = 1
MAX_SEED = 2**31 - 1
DEFAULT_NAME = "{controller} {number}"  # an unnamed kart's display name (number: grid slot from 1)
# every other list and string a request can carry is bounded too (with the body size, server.edge), so that no
# request costs more than a few milliseconds to parse and check on the event loop
MAX_NAME_CHARS = 64  # track, controller, agent and parameter names
MAX_PARAMS = 32  # parameters changed per kart
MAX_PARAM_TEXT = 200  # a text parameter's value
MAX_LANES = 4  # every built-in track has four lanes; the track's own count is checked in server.routes.races
MAX_LAPS = 1000  # a bound on the type; the server's own limit is the setting max_laps


def default_kart_name(controller: str, index: int) -> str:
    """The display name of an unnamed kart: its controller and its number (``index`` + 1), e.g. ``mcts-lqng 1``."""
    return DEFAULT_NAME.format(controller=controller, number=index + 1)
