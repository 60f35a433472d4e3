"""The composition root: the ``karting`` command line, which composes the simulation (:mod:`sim_core`), the
drivers (:mod:`controllers`) and the race server (:mod:`server`, :mod:`web`).

Nothing imports this package (``tests/test_layering.py`` checks it); it is the one place allowed to know every
layer. Run it as ``karting ...`` (the console script) or ``python -m karting ...``.
"""

from sim_core import _numeric_target  # noqa: F401  (one x86-64 level for every library: before numpy is imported)
