"""A catalogue of bad inputs, generated from the configs themselves: every field of every stage that takes --set,
with each kind of bad value its type admits (not a number, NaN, infinite, below its range, above it, not a choice,
a zero or unreadable width). Each must be one line naming the field, exit 1, no traceback, and an unchanged store."""

import dataclasses
import re
import typing

import pytest

from conftest import committed_versions
from lwail_cli import config as cfg

COMMANDS = {  # command line before --set, with refs that need not exist: values are checked first
    "expert-train": ("expert", "train", "InvertedPendulum-v5", "--name", "x"),
    "pretrain-icvf": ("pretrain-icvf", "no-such-data", "--name", "x"),
    "warmup-disc": ("warmup-disc", "no-such-embedding", "no-such-demos", "--name", "x"),
    "imitate": ("imitate", "InvertedPendulum-v5", "--demos", "d", "--embedding", "e", "--disc", "f", "--name", "x"),
}


def _fields(config_class, prefix=""):
    hints = typing.get_type_hints(config_class)
    for f in dataclasses.fields(config_class):
        if dataclasses.is_dataclass(hints[f.name]):
            yield from _fields(hints[f.name], f"{prefix}{f.name}.")
        else:
            yield f"{prefix}{f.name}", hints[f.name], f.metadata


def _bad_values(hint, meta):
    """(text, why) pairs that the field must refuse."""
    kind = typing.get_args(hint)[0] if typing.get_origin(hint) is tuple else hint
    if typing.get_origin(hint) is tuple:
        yield "(0,)", "a zero width"
        yield "(a,b)", "unreadable widths"
        return
    if kind is bool:
        yield "maybe", "not a boolean"
        return
    if kind is str:
        yield "bogus", "not a choice"
        return
    yield "abc", "not a number"
    if kind is float:
        yield "nan", "NaN"
        yield "inf", "infinite"
    else:
        yield "1.5", "not an integer"
    if meta.get("low") is not None:
        yield str(meta["low"] - (1 if kind is int else max(abs(meta["low"]), 1e-9) * 10)), "below its range"
    if meta.get("high") is not None:
        yield str(meta["high"] * 10 + 1), "above its range"
    if meta.get("below") is not None:
        yield str(meta["below"]), "at its exclusive bound"


CASES = [
    pytest.param(command, f"{key}={text}", key, id=f"{command}:{key}={text} ({why})")
    for command in COMMANDS
    for key, hint, meta in _fields(cfg.STAGES[command])
    for text, why in _bad_values(hint, meta)
]


def test_the_catalogue_is_large():
    assert len(CASES) >= 200


@pytest.mark.parametrize("command, assignment, key", CASES)
def test_a_bad_value_is_one_line_naming_its_field(cli, store, command, assignment, key):
    result = cli(*COMMANDS[command], "--set", assignment)
    assert result.exit_code == 1, result.output
    assert "Traceback" not in result.output and result.output.strip().count("\n") == 0, result.output
    assert key.split(".")[-1] in result.output, result.output
    assert re.search(rf"(^|[ .']){re.escape(key)}\b", result.output), result.output  # the field by its whole key, not a namesake
    assert committed_versions(store) == [] and not (store.root / ".runs").exists()
