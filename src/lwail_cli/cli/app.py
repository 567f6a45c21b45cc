"""The ``lwail`` application: its global options, the command decorator and what every command shares (the common
options, the progress bar, the line that says what was written)."""

from __future__ import annotations

import functools
import re
import shlex
import sys
import time
from contextlib import contextmanager
from pathlib import Path
from typing import Optional

import typer
from tqdm import tqdm
from typer.core import TyperCommand

from ..stages.online import WARNING
from ..version import __version__
from ..artifacts import Store
from ..errors import LwailError
from ..names import check_name
from ..settings import resume_may_change
from . import shorthands

# help as click writes it (rich_markup_mode=None): plain text that wraps to the terminal, where Rich's tables squeeze
# each option's help into a narrow column at 80 characters
app = typer.Typer(
    help="LWAIL: imitate an expert from state-only demonstrations. Stages read and write versioned artifacts.",
    no_args_is_help=True,
    pretty_exceptions_enable=False,
    add_completion=False,
    rich_markup_mode=None,
)
expert_app = typer.Typer(help="Train an expert on the true reward and record state-only demonstrations.", no_args_is_help=True,
                         rich_markup_mode=None)
demos_app = typer.Typer(help="Import state-only demonstrations.", no_args_is_help=True, rich_markup_mode=None)
app.add_typer(expert_app, name="expert")
app.add_typer(demos_app, name="demos")


class HelpCommand(TyperCommand):
    """A command whose help names each argument as its metavar alone, as click does: ``lwail imitate [OPTIONS]
    ENV_ID`` (typer writes ``{env_id}`` in the usage line and ``ENV_ID <str>`` in the list)."""

    def collect_usage_pieces(self, ctx) -> list[str]:
        pieces = [self.options_metavar] if self.options_metavar else []
        return pieces + [_usage_word(param) for param in self.get_params(ctx) if param.param_type_name == "argument"]

    def format_options(self, ctx, formatter) -> None:
        params = self.get_params(ctx)
        arguments = [(_argument_word(param), param.help or "") for param in params if param.param_type_name == "argument"]
        options = [param.get_help_record(ctx) for param in params if param.param_type_name == "option"]
        for title, rows in (("Arguments", arguments), ("Options", [row for row in options if row])):
            if rows:
                with formatter.section(title):
                    formatter.write_dl(rows)


def _argument_word(argument) -> str:
    """ENV_ID for env_id (a metavar given overrides it)."""
    return argument.metavar or argument.name.upper()


def _usage_word(argument) -> str:
    word = _argument_word(argument).removesuffix("...")
    word = word if argument.required else f"[{word}]"
    return word + ("..." if argument.nargs != 1 else "")


_state: dict = {"store": None, "tensorboard": None}

# the largest seed every consumer takes: torch takes up to 2**64 - 1, numpy's SeedSequence any, but numpy's legacy
# np.random.seed (which a user's environment may call with it) only up to 2**32 - 1
MAX_SEED = 2**32 - 1
SEED = typer.Option(0, "--seed", metavar="N", help="Random seed.", min=0, max=MAX_SEED)
NAME = typer.Option(None, "--name", metavar="NAME", help="Artifact name (default derived from the env id). A rerun writes a new version.")
DEVICE = typer.Option("auto", "--device", metavar="DEVICE", help="cpu, cuda, cuda:N or auto.")
VIDEO = typer.Option(None, "--video", metavar="DIR", help='Write an MP4 of each episode into this folder (headless; needs: pip install "lwail[video]").')


def resume_option(config_class: type, run: str) -> typer.Option:
    """--resume, its help listing the settings ``config_class`` declares ``resume_may_change``."""
    keys = resume_may_change(config_class)
    budget = " (--steps at the checkpoint's step ends the run there)" if "train.steps" in keys else ""
    return typer.Option(False, "--resume", help=f"Continue the killed {run} of the same name from its last checkpoint; "
                        f"{', '.join(keys[:-1])} and {keys[-1]} may differ{budget}.")


def store() -> Store:
    return Store(_state["store"])


def lwail_line(arguments: str) -> str:
    """``lwail ARGUMENTS`` as the user would type it next, with the --store this command was given (if any)."""
    given = _state["store"]
    return f"lwail --store {shlex.quote(str(given))} {arguments}" if given is not None else f"lwail {arguments}"


def _print_version(value: bool) -> None:
    if value:
        typer.echo(f"lwail {__version__}")
        raise typer.Exit()


@app.callback()
def main(
    store_dir: Optional[Path] = typer.Option(None, "--store", envvar="LWAIL_STORE", metavar="DIR", help="Artifact store directory (default ./artifacts)."),
    threads: Optional[int] = typer.Option(
        None, "--threads", envvar="LWAIL_THREADS", metavar="N", help="CPU threads for torch (default: all cores; use 1 per job when running several).", min=1
    ),
    tensorboard: Optional[Path] = typer.Option(
        None, "--tensorboard", envvar="LWAIL_TENSORBOARD", metavar="DIR", help="Also write every long stage's figures as TensorBoard scalars under this folder."
    ),
    version: bool = typer.Option(False, "--version", callback=_print_version, is_eager=True, help="Print the version and exit."),
) -> None:
    _state["store"] = store_dir
    _state["tensorboard"] = tensorboard
    if threads is not None:
        import torch

        torch.set_num_threads(threads)


def command(parent: typer.Typer, name: str, *, config: type | None = None):
    """Register a command whose LwailError (or OSError from the file system) becomes one line and exit code 1.
    A --name is checked before anything runs (an empty one would otherwise fall back to the default silently).
    With ``config`` (a stage's config class) the command also takes --set and the flags that stand for its settings
    (``shorthands``), and is called with the config they build as its ``config`` argument."""

    def register(function):
        @functools.wraps(function)
        def wrapper(*args, **kwargs):
            try:
                if kwargs.get("name") is not None:
                    check_name(kwargs["name"])
                if config is not None:
                    kwargs = shorthands.build_config(config, kwargs)
                return function(*args, **kwargs)
            except LwailError as exc:
                typer.echo(f"error: {' '.join(str(exc).splitlines())}", err=True)  # one line, whatever an env's exception said
                raise typer.Exit(1) from None
            except OSError as exc:  # the machine, not lwail: a store that is a file, read-only, a full disk
                where = f" ({exc.filename})" if exc.filename else ""
                typer.echo(f"error: {exc.strerror or exc}{where}; writes are atomic, so nothing was half-written", err=True)
                raise typer.Exit(1) from None
            except KeyboardInterrupt:
                typer.echo("interrupted: the last checkpoint (if any) is kept; rerun with --resume", err=True)
                raise typer.Exit(130) from None

        if config is not None:
            wrapper.__signature__ = shorthands.signature(function, config)
        return parent.command(name, cls=HelpCommand)(wrapper)

    return register


@contextmanager
def progress_bar(description: str, total: int, warnings: list[str] = ()):
    """A tqdm bar that appears on the first report, after the ``warnings`` (so input errors print alone); yields the
    stages' callback. With --tensorboard, every figure reported (an evaluation's whole CSV row included) is also a scalar."""
    bars: list[tqdm] = []
    scalars = tensorboard_writer(description)

    def report(done: int, shown: dict) -> None:
        if not bars:
            warn(warnings)
            # steps done before the bar appears (a resumed run's, or the first report's) are not counted in its rate
            bars.append(tqdm(total=total, initial=done, desc=description, unit="step", dynamic_ncols=True, file=sys.stderr, mininterval=0.5))
        bars[0].update(done - bars[0].n)
        if WARNING in shown:
            bars[0].write(shown.pop(WARNING), file=sys.stderr)
        if shown:
            bars[0].set_postfix({key: fmt(value) for key, value in shown.items() if "/" not in key}, refresh=False)
        if scalars is not None:
            for key, value in shown.items():
                if isinstance(value, (int, float)) and not isinstance(value, bool):
                    scalars.add_scalar(key, value, done)

    try:
        yield report
    finally:
        if bars:
            bars[0].close()
        if scalars is not None:
            scalars.close()


def tensorboard_writer(description: str):
    """A SummaryWriter for one stage's run (None without --tensorboard)."""
    if _state["tensorboard"] is None:
        return None
    try:
        from torch.utils.tensorboard import SummaryWriter
    except ImportError:
        raise LwailError('--tensorboard needs the tensorboard package: pip install "lwail[tensorboard]"') from None
    run = re.sub(r"[^A-Za-z0-9._-]+", "_", description).strip("_")
    return SummaryWriter(log_dir=str(Path(_state["tensorboard"]) / f"{run}-{time.strftime('%Y%m%d-%H%M%S')}"))


def refuse_unread_settings(config, seed: int, *, settings: str, reader: str) -> None:
    """An import reads a file as it is: a setting or seed given beside it would do nothing, so it is refused, not ignored."""
    if config != type(config)() or seed != SEED.default:
        raise LwailError(f"{settings} and --seed are for {reader}; an import takes the file as it is")


def warn(lines: list[str]) -> None:
    for line in lines:
        typer.echo(f"warning: {line}", err=True)


def say_written(artifact) -> None:
    if artifact.reused:
        typer.echo(f"already in the store: {artifact.ref}  ({artifact.path}) holds the same content (hash {artifact.hash[:12]}); nothing written")
        return
    typer.echo(f"wrote {artifact.ref}  ({artifact.path})")
    if artifact.metrics:
        typer.echo("  " + "  ".join(f"{k}={fmt(v)}" for k, v in artifact.metrics.items()))


def fmt(value) -> str:
    return f"{value:.4g}" if isinstance(value, float) else str(value)
