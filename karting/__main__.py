"""``python -m karting ...``: the same command line as the ``karting`` console script."""

from karting.cli import app

app(prog_name="karting")
