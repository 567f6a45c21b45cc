"""Flags that stand for settings: ``--steps 5000`` is ``--set train.steps=5000``, each declared once, here.

A command registered with a config class takes ``--set`` and the flags of that config's settings; their defaults
and help come from the settings themselves, so ``--help`` and ``lwail defaults`` agree. A flag and a ``--set`` of the
same key must agree; either alone sets the key."""

from __future__ import annotations

import dataclasses
import inspect
import typing
from collections.abc import Iterator

import typer
from typer.models import ArgumentInfo

from .. import config as cfg
from ..errors import LwailError
from ..settings import read_assignments, with_values

FLAGS: dict[type, dict[str, str]] = {  # config class -> its settings that have a flag: field -> flag
    cfg.EnvConfig: {"start_noise": "--start-noise"},
    cfg.CollectConfig: {"transitions": "--transitions"},
    cfg.RecordConfig: {"episodes": "--episodes"},
    cfg.TrainConfig: {"steps": "--steps", "eval_every": "--eval-every", "checkpoint_every": "--checkpoint-every"},
    cfg.EmbedConfig: {"kind": "--kind"},
    cfg.ICVFConfig: {"steps": "--steps", "batch_size": "--batch-size", "embedding_dim": "--embedding-dim"},
    cfg.WarmupConfig: {"expert_episodes": "--expert-episodes"},
    cfg.ImitationConfig: {"method": "--method", "expert_episodes": "--expert-episodes"},
    cfg.EvalConfig: {"episodes": "--episodes", "seed": "--seed"},
}
SET = typer.Option([], "--set", metavar="KEY=VALUE", help="Override any hyper-parameter: field=value or section.field=value (see `lwail defaults`). Repeatable, "
                   "each key once, applied together (their order never matters). Lists: 64,64 or [64, 64]; [] is no hidden layer (a linear map).")
CONTEXT = "lwail_context"  # the click context, which says whether a flag was given or left at its default


@dataclasses.dataclass(frozen=True)
class Shorthand:
    key: str  # as --set names it, e.g. train.steps
    flag: str
    hint: type
    default: object
    doc: str

    @property
    def parameter(self) -> str:
        return "setting_" + self.key.replace(".", "_")

    @property
    def metavar(self) -> str:
        """What --help writes after the flag: N for a count, X for a number, else the flag's name (--kind KIND)."""
        return {int: "N", float: "X"}.get(self.hint, self.flag.lstrip("-").upper().replace("-", "_"))


def shorthands(config, prefix: str = "") -> Iterator[Shorthand]:
    """The flags of ``config``'s settings and of its sections' settings, in the order the fields are declared."""
    hints = typing.get_type_hints(type(config))
    for f in dataclasses.fields(config):
        value = vars(config)[f.name]  # through vars: reading a default is not using the setting (tests/test_config_usage.py)
        if dataclasses.is_dataclass(value):
            yield from shorthands(value, f"{prefix}{f.name}.")
        elif f.name in FLAGS.get(type(config), {}):
            yield Shorthand(prefix + f.name, FLAGS[type(config)][f.name], hints[f.name], value, f.metadata["doc"])


def signature(function, config_type: type) -> inspect.Signature:
    """``function``'s parameters but its ``config``, with the config's flags after its arguments and required options,
    then --set (and the context that tells a given flag from a default)."""
    hints = typing.get_type_hints(function)
    own = [parameter.replace(annotation=hints[parameter.name]) for parameter in inspect.signature(function).parameters.values()
           if parameter.name != "config"]
    leading = next((i for i, parameter in enumerate(own) if not _is_required(parameter)), len(own))
    flags = [
        inspect.Parameter(shorthand.parameter, inspect.Parameter.KEYWORD_ONLY, annotation=shorthand.hint, default=typer.Option(
            shorthand.default, shorthand.flag, metavar=shorthand.metavar, help=f"--set {shorthand.key}: {shorthand.doc}."))
        for shorthand in shorthands(config_type())
    ]
    extra = [inspect.Parameter("overrides", inspect.Parameter.KEYWORD_ONLY, annotation=list[str], default=SET),
             inspect.Parameter(CONTEXT, inspect.Parameter.KEYWORD_ONLY, annotation=typer.Context)]
    parameters = [parameter.replace(kind=inspect.Parameter.KEYWORD_ONLY) for parameter in own[:leading] + flags + own[leading:]] + extra
    return inspect.Signature(parameters, return_annotation=None)


def _is_required(parameter: inspect.Parameter) -> bool:
    """An argument, or an option without a default: what the command is about comes before its settings."""
    return isinstance(parameter.default, ArgumentInfo) or getattr(parameter.default, "default", None) is ...


def build_config(config_type: type, arguments: dict) -> dict:
    """The command's own arguments, and the config its flags and --set build (as ``config``)."""
    arguments = dict(arguments)
    context: typer.Context = arguments.pop(CONTEXT)
    defaults = config_type()
    given = read_assignments(defaults, arguments.pop("overrides"))
    for shorthand in shorthands(defaults):
        value = arguments.pop(shorthand.parameter)
        if context.get_parameter_source(shorthand.parameter).name == "DEFAULT":  # by name: typer may bundle its own click
            continue
        if shorthand.key in given and given[shorthand.key] != value:
            raise LwailError(f"{shorthand.flag} {value} and --set {shorthand.key}={given[shorthand.key]} disagree")
        given[shorthand.key] = value
    return {**arguments, "config": with_values(defaults, given)}
