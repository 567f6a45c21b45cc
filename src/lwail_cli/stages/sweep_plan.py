"""A sweep's plan (TOML): the grid of tasks × seeds × embedding arms and each stage's overrides, read and checked
whole before anything runs (`lwail sweep`, and `lwail report` rebuilding it from a report's record).

An entry of ``embeddings`` is a kind (``embeddings.EMBEDDINGS``) or the name of a variant, a ``[variants.NAME]`` table
giving its kind and its own overrides of the stages after collect (an ablation such as φ with LayerNorm is one more
arm of the grid). ``[[also]]`` tables add grids of their own (e.g. a second seed of some tasks and arms only) to the same
plan, run after the first grid and reported with it. Every artifact of a run is named after the sweep, task, seed
and arm; ``[labels]`` gives an arm the public name the report's tables and figures show (the arm's own by default).
An ``[axis]`` table varies one setting as the grid varies seeds: ``setting = "env.start_noise"``, ``values = [0.0,
0.5]`` (and a short ``name``, the field's by default) make each arm one arm per value, ``<arm>-<name><value>``, the
setting given to every stage after collect whose config holds it (data set I stays shared by the arms of a seed).
Arms whose pre-training configs are equal read one φ, named after the first of them (``SweepPlan.phi_of``): an axis
that does not reach φ, such as the start-state noise, varies the imitation on the same φ.
``methods`` (``["lwail"]`` where not given) varies the imitation method the same way: every method of a task, seed and
arm imitates on the same data set I and φ (made once, read by all), and only a method that reads a discriminator warms
one up. A plan of LWAIL alone names its runs after their arm; one with other methods, ``<arm>-<method>``.
"""

from __future__ import annotations

import tomllib
from dataclasses import dataclass, field
from functools import cached_property
from pathlib import Path

from .. import config as cfg
from ..embeddings import EMBEDDINGS
from ..errors import LwailError
from ..methods import METHODS
from ..names import check_name
from .declaration import FROM_GRID, PLAN_STAGES, read_table, stage_config
from .demos import bundled_demos_path
from .sweep_grid import DEFAULT_METHODS, Grid, SweepRun, along_axis, read_grid

__all__ = ["SweepPlan", "SweepRun", "grid_lines", "plan_from_dict", "read_plan", "select_runs"]

GRID_KEYS = {"tasks", "seeds", "embeddings", "methods"}
PLAN_KEYS = {"name", *GRID_KEYS, "also", "set", "variants", "threads", "labels", "axis"}
VARIANT_STAGES = PLAN_STAGES[1:]  # data set I is shared by every embedding of a seed, so collect is the plan's alone


@dataclass(frozen=True)
class SweepPlan:
    name: str
    grids: tuple[Grid, ...]  # the plan's own grid, then its [[also]] grids, in the order they run
    overrides: dict  # stage -> tuple of section.field=value assignments
    variants: dict = field(default_factory=dict)  # name -> {"kind": an embedding kind, stage: assignments}
    threads: int = 1  # CPUs (Ray) and torch threads per run: 1 when runs share the cores, more for a lone run
    labels: dict = field(default_factory=dict)  # arm -> its public name in the report (e.g. "no embedding")

    @property
    def runs(self) -> list[SweepRun]:
        """Every grid's runs in order, each once."""
        named = self.methods != list(DEFAULT_METHODS)
        return list(dict.fromkeys(run for grid in self.grids for run in grid.runs(named)))

    @property
    def methods(self) -> list[str]:
        return list(dict.fromkeys(method for grid in self.grids for method in grid.methods))

    @property
    def arms(self) -> list[str]:
        """Each run's arm (embedding arm × method) once, in the plan's order: the report's rows and colours."""
        return list(dict.fromkeys(run.arm for run in self.runs))

    @property
    def tasks(self) -> list[str]:
        return list(dict.fromkeys(run.task for run in self.runs))

    @property
    def kinds(self) -> list[str]:
        return list(dict.fromkeys(run.kind for run in self.runs))

    @property
    def data_sets(self) -> list[tuple[str, int]]:
        """The (task, seed) of each data set I, shared by the runs of every arm of that task and seed."""
        return list(dict.fromkeys((run.task, run.seed) for run in self.runs))

    @property
    def phis(self) -> list[tuple[str, int, str]]:
        """The (task, seed, φ arm) of each φ, shared by the runs of every method of every arm that reads it."""
        return list(dict.fromkeys(self.phi_of(run) for run in self.runs))

    def phi_of(self, run: SweepRun) -> tuple[str, int, str]:
        """The (task, seed, φ arm) of the φ the run reads."""
        return run.task, run.seed, self._phi_arms[run.kind]

    @cached_property
    def _phi_arms(self) -> dict[str, str]:
        """Each arm -> the plan's first arm with the same pre-training config, whose φ it reads: arms that differ only
        after φ (an [axis] over env.start_noise, a critic ablation) imitate on one φ, made once, so they differ by
        nothing else."""
        first: dict[str, str] = {}
        for arm in self.kinds:
            first.setdefault(repr(cfg.to_dict(self.config("pretrain-icvf", arm))), arm)
        return {arm: first[repr(cfg.to_dict(self.config("pretrain-icvf", arm)))] for arm in self.kinds}

    def label(self, arm: str) -> str:
        return self.labels.get(arm, arm)

    def run_label(self, run: SweepRun) -> str:
        """The public name of the run's arm: its embedding arm's, and its method's where the plan has several."""
        method = f", {METHODS[run.imitation].label}" if len(self.methods) > 1 else ""
        return self.label(run.kind) + method

    def embedding_kind(self, arm: str) -> str:
        return self.variants[arm]["kind"] if arm in self.variants else arm

    def config(self, stage: str, arm: str | None = None, method: str | None = None):
        """The stage's validated config: defaults, the plan's overrides, the arm's variant overrides, and what the
        grid gives: for pretrain-icvf the arm's embedding kind, for imitate the method (LWAIL where none is named)."""
        variant = self.variants.get(arm, {})
        given = {"pretrain-icvf": self.embedding_kind(arm) if arm is not None else None, "imitate": method or DEFAULT_METHODS[0]}
        fixed = (f"{FROM_GRID[stage][0]}={given[stage]}",) if given.get(stage) is not None else ()
        return stage_config(stage, self.overrides.get(stage, ()), variant.get(stage, ()), fixed)

    def run_config(self, stage: str, run: SweepRun):
        return self.config(stage, run.kind, run.imitation)

    def demos_name(self, task: str) -> str:
        return f"{self.name}-{task.lower()}-demos"

    def dataset_name(self, task: str, seed: int) -> str:
        return f"{self.name}-{task.lower()}-s{seed}-data"

    def phi_name(self, task: str, seed: int, phi_arm: str) -> str:
        """The name of the φ of ``phi_of``'s (task, seed, φ arm)."""
        return f"{self.name}-{task.lower()}-s{seed}-{phi_arm}"

    def names(self, run: SweepRun) -> dict[str, str]:
        """Each artifact's name, by kind."""
        base = f"{self.name}-{run.task.lower()}-s{run.seed}"
        return {"demos": self.demos_name(run.task), "dataset": self.dataset_name(run.task, run.seed), "embedding": self.phi_name(*self.phi_of(run)),
                "discriminator": f"{base}-{run.kind}-disc", "policy": f"{base}-{run.arm}"}

    def to_dict(self) -> dict:
        also = {"also": [grid.to_dict() for grid in self.grids[1:]]} if len(self.grids) > 1 else {}
        labels = {"labels": dict(self.labels)} if self.labels else {}
        return {"name": self.name, **self.grids[0].to_dict(), **also, **labels,
                "set": {stage: list(assignments) for stage, assignments in self.overrides.items()},
                "variants": {name: {key: value if key == "kind" else list(value) for key, value in variant.items()}
                             for name, variant in self.variants.items()}, "threads": self.threads}


def select_runs(plan: SweepPlan, selectors: list[str]) -> list[SweepRun]:
    """The plan's runs that any of ``selectors`` picks, in the plan's order (all of them without a selector). A
    selector is ``TASK[:SEED[:ARM]]``, each part a value of the plan's grid or ``*`` (any), e.g. ``Walker2d-v5:0``,
    ``*:1:identity``; one that picks no run, or names what the plan has not, is refused in one line."""
    if not selectors:
        return plan.runs
    picked: set[SweepRun] = set()
    for selector in selectors:
        parts = selector.split(":")
        if len(parts) > 3 or "" in parts:
            raise LwailError(f"--only {selector!r}: give TASK[:SEED[:ARM]], each part a value of the plan or * (e.g. Walker2d-v5:0:icvf)")
        grid = {"task": plan.tasks, "seed": [str(seed) for seed in dict.fromkeys(run.seed for run in plan.runs)], "arm": plan.arms}
        for (axis, values), part in zip(grid.items(), parts):
            if part != "*" and part not in values:
                raise LwailError(f"--only {selector!r}: the plan has no {axis} {part!r}; its {axis}s: {', '.join(values)}")
        wanted = dict(zip(grid, parts))
        matches = {run for run in plan.runs
                   if all(wanted.get(axis, "*") in ("*", str(value)) for axis, value in (("task", run.task), ("seed", run.seed), ("arm", run.arm)))}
        if not matches:
            raise LwailError(f"--only {selector!r} picks no run of the plan (its grid has no run with all of these)")
        picked |= matches
    return [run for run in plan.runs if run in picked]


def grid_lines(plan: SweepPlan, runs: list[SweepRun] | None = None) -> list[str]:
    """The plan as it will run (``runs``: those of it that will, default all): its overrides, then each run with its
    embedding kind and its arm's own overrides."""
    lines = [f"[set] {stage}: {', '.join(assignments)}" for stage, assignments in plan.overrides.items()]
    for run in plan.runs if runs is None else runs:
        own = "; ".join(f"{stage}: {', '.join(assignments)}" for stage, assignments in plan.variants.get(run.kind, {}).items() if stage != "kind")
        phi = plan.phi_of(run)[2]
        shared = f", the φ of {phi}" if phi != run.kind else ""
        lines.append(f"{run.label} ({plan.embedding_kind(run.kind)}{shared}, {run.imitation})" + (f"  {own}" if own else ""))
    return lines


def read_plan(path: Path) -> SweepPlan:
    try:
        raw = tomllib.loads(Path(path).read_text())
    except FileNotFoundError:
        raise LwailError(f"no plan file {path}") from None
    except (OSError, UnicodeDecodeError) as exc:
        raise LwailError(f"cannot read the plan {path}: {exc}") from None
    except tomllib.TOMLDecodeError as exc:
        raise LwailError(f"{path} is not valid TOML: {exc}") from None
    return plan_from_dict(raw, str(path))


def plan_from_dict(raw: dict, source: str) -> SweepPlan:
    """A plan, checked whole (names, grid, every stage's config) before anything runs."""
    unknown = set(raw) - PLAN_KEYS
    if unknown:
        raise LwailError(f"{source}: unknown keys {sorted(unknown)}; a plan has {sorted(PLAN_KEYS)}")
    name = raw.get("name")
    if not isinstance(name, str):
        raise LwailError(f"{source}: 'name' must be a string naming the sweep")
    check_name(name)
    variants = _read_variants(raw.get("variants", {}), source)
    also = raw.get("also", [])
    if not isinstance(also, list) or not all(isinstance(table, dict) for table in also):
        raise LwailError(f"{source}: 'also' must be [[also]] tables, each with its own tasks, seeds and embeddings")
    grids = (read_grid(raw, source, variants),
             *(read_grid(table, f"{source}: [[also]] table {number}", variants, keys=GRID_KEYS) for number, table in enumerate(also, 1)))
    unused = sorted(set(variants) - {kind for grid in grids for kind in grid.kinds})
    if unused:
        raise LwailError(f"{source}: [variants] {', '.join(unused)} defined but not listed in 'embeddings'")
    threads = raw.get("threads", 1)
    if isinstance(threads, bool) or not isinstance(threads, int) or not 1 <= threads <= 256:
        raise LwailError(f"{source}: 'threads' must be an integer from 1 to 256 (CPUs per run), got {threads!r}")
    labels = raw.get("labels", {})
    arms = {kind for grid in grids for kind in grid.kinds}
    if not isinstance(labels, dict) or not all(isinstance(label, str) and label.strip() for label in labels.values()):
        raise LwailError(f"{source}: [labels] must map arms to non-empty public names, e.g. identity = \"no embedding\"")
    if not set(labels) <= arms:
        raise LwailError(f"{source}: [labels] names {sorted(set(labels) - arms)}, which are not arms of the plan ({sorted(arms)})")
    if "axis" in raw:
        grids, variants, labels = along_axis(raw["axis"], f"{source}: [axis]", grids, variants, labels, VARIANT_STAGES)
    plan = SweepPlan(name, grids, read_table(raw.get("set", {}), PLAN_STAGES, f"{source}: [set]"), variants, threads, labels)
    for task in plan.tasks:
        bundled_demos_path(task)  # refuses a task without bundled demos
    for stage in PLAN_STAGES:
        for arm in plan.kinds:
            for method in plan.methods:
                plan.config(stage, arm, method)
    for run in plan.runs:
        for artifact_name in plan.names(run).values():
            check_name(artifact_name)
    return plan


def _read_variants(table, source: str) -> dict[str, dict]:
    if not isinstance(table, dict):
        raise LwailError(f"{source}: [variants] must hold one table per variant, [variants.NAME]")
    variants = {}
    for name, variant in table.items():
        where = f"{source}: [variants.{name}]"
        if name in EMBEDDINGS:
            raise LwailError(f"{where} would shadow the embedding kind {name}; give the variant another name")
        check_name(name)
        if not isinstance(variant, dict) or variant.get("kind") not in EMBEDDINGS:
            raise LwailError(f"{where} needs kind = one of {list(EMBEDDINGS)}")
        stages = {key: value for key, value in variant.items() if key != "kind"}
        variants[name] = {"kind": variant["kind"], **read_table(stages, VARIANT_STAGES, where)}
    return variants


