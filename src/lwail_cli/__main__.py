"""``python -m lwail_cli`` is the ``lwail`` command."""

from .cli import app

app(prog_name="lwail")
