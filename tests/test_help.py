"""Every help text reads on screen as written: Rich, which draws typer's help, takes ``[word]`` for a style tag and
drops it unless escaped (``lwail[video]`` showed as ``lwail``, ``name[@vN]`` as ``name``)."""

import click
import typer
from rich.text import Text

from lwail_cli.cli import app


def _help_texts(command: click.Command, path: str = "lwail"):
    yield path, command.help or ""
    for param in command.params:
        yield f"{path} {param.name}", getattr(param, "help", None) or ""
    for name, sub in getattr(command, "commands", {}).items():
        yield from _help_texts(sub, f"{path} {name}")


def test_no_help_text_loses_a_bracketed_word_to_rich_markup():
    texts = list(_help_texts(typer.main.get_command(app)))
    assert any("lwail[video]" in text.replace("\\[", "[") for _, text in texts)  # the walk reaches the options
    lost = [(where, text) for where, text in texts if Text.from_markup(text).plain != text.replace("\\[", "[")]
    assert not lost, lost
