"""The ``lwail`` command line: parses arguments, shows progress, prints results. Nothing more.

``app`` (global options, the command decorator, what commands share) is in ``app.py``; each ``*_commands`` module
adds one group of commands to it, and ``shorthands.py`` declares the flags that stand for settings."""

# importing a module registers its commands, in the order `lwail --help` lists them
from . import stage_commands, result_commands, store_commands  # noqa: F401, I001
from .app import app

__all__ = ["app"]
