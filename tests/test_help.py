"""Every help text reads on an 80-column terminal as written: plain text as click wraps it (no Rich tables squeezing
each option's help into a narrow column), arguments and values named by a word (ENV_ID, N, REF), not by typer's
``{env_id}`` or ``<int>``, and no markup escape (``\\[``) left in a text."""

import re

import pytest
import typer
from typer.testing import CliRunner

from lwail_cli.cli import app
from lwail_cli.stages.demos import bundled_demos_path
from lwail_cli.stages.shared import bundled_experts, reference_for_env


def _commands(command, path=()):
    yield path, command
    for name, sub in getattr(command, "commands", {}).items():
        yield from _commands(sub, (*path, name))


COMMANDS = list(_commands(typer.main.get_command(app)))


def _help(path) -> str:
    result = CliRunner().invoke(app, [*path, "--help"], env={"COLUMNS": "80"}, prog_name="lwail")
    assert result.exit_code == 0, result.output
    return result.output


@pytest.mark.parametrize("path", [path for path, _ in COMMANDS], ids=lambda path: " ".join(path) or "lwail")
def test_help_reads_at_80_columns_without_placeholders(path):
    text = _help(path)
    assert text.startswith(f"Usage: lwail {' '.join(path)}".rstrip())
    assert max(map(len, text.splitlines())) <= 80, text
    assert not re.search(r"<(bool|str|int|float|path|list)[^>]*>|\{[a-z_]+\}|\\\[|[╭│╰]", text), text


def test_every_help_text_is_shown_as_written():
    texts = [(path, param.name, getattr(param, "help", None) or "") for path, command in COMMANDS for param in command.params]
    texts += [(path, "", command.help or "") for path, command in COMMANDS]
    assert any('"lwail[video]"' in text for _, _, text in texts)  # the walk reaches the options
    assert not [where for where in texts if "\\" in where[2]]


def test_eval_help_names_the_reference_normalized_uses_for_each_bundled_task():
    text = " ".join(_help(("eval",)).split())
    for task in bundled_experts():
        bundled_demos_path(task)
        source = reference_for_env(task).source
        if source.startswith("D4RL"):  # D4RL's numbers were measured on the -v2 tasks, whatever version is run
            assert task.split("-v")[0] in text and "-v2" in text, task
        else:
            assert "the bundled expert's" in text and "random policy's return" in text, (task, source)
