"""The chain's settings as declared: tables of stage → ``field=value`` assignments, read and checked alike wherever
they come from (a sweep plan's ``[set]`` and ``[variants.NAME]`` tables, the bundled quickstart preset, quickstart's
``--set STAGE:field=value``), and each stage's config built from its layers of them, a later layer winning.

The quickstart preset (``quickstart.toml`` beside this module) is such a table per task: the one place quickstart's
short budgets live; a task it does not name runs every stage's defaults.
"""

from __future__ import annotations

import dataclasses
import json
import tomllib
from importlib import resources

from .. import config as cfg
from ..errors import LwailError
from .chain import CHAIN

PLAN_STAGES = (*CHAIN, "eval")  # the stages a declaration may set, each a command of config.STAGES
# the settings a sweep plan gives from its grid, never from a table: the arm's embedding kind and the run's method
FROM_GRID = {"pretrain-icvf": ("kind", "'embeddings' (or a variant's kind)"), "imitate": ("method", "'methods'")}
PRESET = "quickstart.toml"


def read_table(table, stages: tuple[str, ...], where: str, *, from_grid: bool = True) -> dict[str, tuple[str, ...]]:
    """``{stage: ["field=value", ...]}`` checked for its shape (each value's name and type when a config is built from
    it); with ``from_grid``, a setting the plan's grid gives (``FROM_GRID``) is refused."""
    if not isinstance(table, dict) or not set(table) <= set(stages):
        raise LwailError(f"{where} may hold lists of field=value for the stages {list(stages)}")
    for stage, assignments in table.items():
        if not isinstance(assignments, list) or not all(isinstance(a, str) for a in assignments):
            raise LwailError(f"{where} {stage} must be a list of \"field=value\" strings")
        if from_grid and stage in FROM_GRID and any(a.partition("=")[0].strip() == FROM_GRID[stage][0] for a in assignments):
            field, source = FROM_GRID[stage]
            raise LwailError(f"{where}: the {'embedding kind' if field == 'kind' else field} comes from {source}, not from {stage}")
    return {stage: tuple(assignments) for stage, assignments in table.items()}


def stage_config(stage: str, *layers: tuple[str, ...]):
    """The stage's validated config: its defaults with each layer of assignments over the one before."""
    return cfg.with_overrides(cfg.STAGES[stage](), *layers)


def holds(stage: str, setting: str) -> bool:
    """Whether the stage's config has the setting (``section.field``, as --set names it)."""
    node = cfg.STAGES[stage]()
    for part in setting.split("."):
        if not dataclasses.is_dataclass(node) or part not in {f.name for f in dataclasses.fields(node)}:
            return False
        node = vars(node)[part]
    return not dataclasses.is_dataclass(node)


def read_stage_assignments(assignments: list[str], stages: tuple[str, ...] = PLAN_STAGES) -> dict[str, tuple[str, ...]]:
    """``STAGE:field=value`` assignments (a command that runs several stages) as a table; one line for a missing or
    unknown stage, naming the stages whose config holds the setting."""
    table: dict[str, list[str]] = {}
    for assignment in assignments:
        stage, colon, setting = assignment.partition(":")
        if not colon or "=" in stage:
            key = assignment.partition("=")[0].strip()
            holders = [name for name in stages if holds(name, key)]
            where = f"stages with {key}: {', '.join(holders)}" if holders else f"no stage has {key}: `lwail defaults STAGE` lists each one's"
            raise LwailError(f"--set {assignment}: name the stage, STAGE:{assignment} ({where})")
        if stage.strip() not in stages:
            raise LwailError(f"--set {assignment}: unknown stage {stage.strip()!r}; the stages are {', '.join(stages)}")
        table.setdefault(stage.strip(), []).append(setting)
    return read_table(table, stages, "--set", from_grid=False)


def preset(env_id: str) -> dict[str, tuple[str, ...]]:
    """The quickstart preset's table for ``env_id`` (empty: every stage's defaults)."""
    return presets().get(env_id, {})


def presets() -> dict[str, dict[str, tuple[str, ...]]]:
    """Every table of the bundled quickstart preset, by task, each checked as a plan's [set] is."""
    raw = tomllib.loads(resources.files(__package__).joinpath(PRESET).read_text())
    return {task: read_table(table, PLAN_STAGES, f"{PRESET}: [{task}]", from_grid=False) for task, table in raw.items()}


def table_lines(table: dict[str, tuple[str, ...]]) -> list[str]:
    """A table as the lines a plan's [set] would hold: ``stage = ["field=value", ...]``."""
    return [f"{stage} = {json.dumps(list(assignments))}" for stage, assignments in table.items()]
