"""Running many races: tournaments (round robin, in worker processes or on Ray), the paper's statistics over
their results (and over the original implementation's released logs), and reports.

Composes :mod:`sim_core` and :mod:`controllers`; knows nothing of HTTP, asyncio or the server (which stores the
races through the :class:`arena.tournament.RaceStore` protocol).
"""

from sim_core import _numeric_target  # noqa: F401  (one x86-64 level for every library: before numpy is imported)
