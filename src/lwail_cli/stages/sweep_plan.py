"""A sweep's plan (TOML): the grid of tasks × seeds × embedding arms and each stage's overrides, read and checked
whole before anything runs (`lwail sweep`, and `lwail report` rebuilding it from a report's record).

An entry of ``embeddings`` is a kind (icvf, identity) or the name of a variant, a ``[variants.NAME]`` table giving
its kind and its own overrides of the stages after collect (an ablation such as φ without LayerNorm is one more arm
of the grid). Every artifact of a run is named after the sweep, task, seed and arm.
"""

from __future__ import annotations

import tomllib
from dataclasses import dataclass, field
from pathlib import Path

from .. import config as cfg
from ..errors import LwailError
from ..names import check_name
from .chain import CHAIN
from .demos import bundled_demos_path

PLAN_STAGES = (*CHAIN, "eval")
EMBEDDINGS = ("icvf", "identity")
PLAN_KEYS = {"name", "tasks", "seeds", "embeddings", "set", "variants", "threads"}
VARIANT_STAGES = PLAN_STAGES[1:]  # data set I is shared by every embedding of a seed, so collect is the plan's alone


@dataclass(frozen=True)
class SweepRun:
    task: str
    seed: int
    kind: str

    @property
    def label(self) -> str:
        return f"{self.task} seed {self.seed} {self.kind}"


@dataclass(frozen=True)
class SweepPlan:
    name: str
    tasks: tuple[str, ...]
    seeds: tuple[int, ...]
    kinds: tuple[str, ...]  # the grid's embedding arms: icvf, identity or a variant's name
    overrides: dict  # stage -> tuple of section.field=value assignments
    variants: dict = field(default_factory=dict)  # name -> {"kind": icvf|identity, stage: assignments}
    threads: int = 1  # CPUs (Ray) and torch threads per run: 1 when runs share the cores, more for a lone run

    @property
    def runs(self) -> list[SweepRun]:
        return [SweepRun(task, seed, kind) for task in self.tasks for seed in self.seeds for kind in self.kinds]

    def embedding_kind(self, arm: str) -> str:
        return self.variants[arm]["kind"] if arm in self.variants else arm

    def config(self, stage: str, arm: str | None = None):
        """The stage's validated config: defaults, the plan's overrides, the arm's variant overrides, and for
        pretrain-icvf the arm's embedding kind."""
        variant = self.variants.get(arm, {})
        fixed = [f"kind={self.embedding_kind(arm)}"] if stage == "pretrain-icvf" and arm is not None else []
        return cfg.with_overrides(cfg.STAGES[stage](), self.overrides.get(stage, ()), variant.get(stage, ()), fixed)

    def names(self, run: SweepRun) -> dict[str, str]:
        """Each artifact's name, by kind."""
        base = f"{self.name}-{run.task.lower()}-s{run.seed}"
        return {"demos": f"{self.name}-{run.task.lower()}-demos", "dataset": f"{base}-data", "embedding": f"{base}-{run.kind}",
                "discriminator": f"{base}-{run.kind}-disc", "policy": f"{base}-{run.kind}"}

    def to_dict(self) -> dict:
        return {"name": self.name, "tasks": list(self.tasks), "seeds": list(self.seeds), "embeddings": list(self.kinds),
                "set": {stage: list(assignments) for stage, assignments in self.overrides.items()},
                "variants": {name: {key: value if key == "kind" else list(value) for key, value in variant.items()}
                             for name, variant in self.variants.items()}, "threads": self.threads}


def read_plan(path: Path) -> SweepPlan:
    try:
        raw = tomllib.loads(Path(path).read_text())
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
    name, tasks, seeds, kinds = raw.get("name"), raw.get("tasks"), raw.get("seeds"), raw.get("embeddings", ["icvf", "identity"])
    if not isinstance(name, str):
        raise LwailError(f"{source}: 'name' must be a string naming the sweep")
    check_name(name)
    if not _unique_list(tasks, str):
        raise LwailError(f"{source}: 'tasks' must be a non-empty list of distinct env ids")
    if not _unique_list(seeds, int) or min(seeds) < 0 or max(seeds) >= 2**31:
        raise LwailError(f"{source}: 'seeds' must be a non-empty list of distinct integers in [0, 2^31)")
    variants = _read_variants(raw.get("variants", {}), source)
    if not _unique_list(kinds, str) or not set(kinds) <= set(EMBEDDINGS) | set(variants):
        raise LwailError(f"{source}: 'embeddings' must be a non-empty list drawn from {list(EMBEDDINGS)} and the plan's [variants]")
    unused = sorted(set(variants) - set(kinds))
    if unused:
        raise LwailError(f"{source}: [variants] {', '.join(unused)} defined but not listed in 'embeddings'")
    threads = raw.get("threads", 1)
    if isinstance(threads, bool) or not isinstance(threads, int) or not 1 <= threads <= 256:
        raise LwailError(f"{source}: 'threads' must be an integer from 1 to 256 (CPUs per run), got {threads!r}")
    plan = SweepPlan(name, tuple(tasks), tuple(seeds), tuple(kinds), _read_overrides(raw.get("set", {}), PLAN_STAGES, f"{source}: [set]"),
                     variants, threads)
    for task in plan.tasks:
        bundled_demos_path(task)  # refuses a task without bundled demos
    for stage in PLAN_STAGES:
        for arm in plan.kinds:
            plan.config(stage, arm)
    for run in plan.runs:
        for artifact_name in plan.names(run).values():
            check_name(artifact_name)
    return plan


def _read_overrides(table, stages: tuple[str, ...], where: str) -> dict[str, tuple[str, ...]]:
    if not isinstance(table, dict) or not set(table) <= set(stages):
        raise LwailError(f"{where} may hold lists of field=value for the stages {list(stages)}")
    for stage, assignments in table.items():
        if not isinstance(assignments, list) or not all(isinstance(a, str) for a in assignments):
            raise LwailError(f"{where} {stage} must be a list of \"field=value\" strings")
        if stage == "pretrain-icvf" and any(a.partition("=")[0].strip() == "kind" for a in assignments):
            raise LwailError(f"{where}: the embedding kind comes from 'embeddings' (or a variant's kind), not from pretrain-icvf")
    return {stage: tuple(assignments) for stage, assignments in table.items()}


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
        variants[name] = {"kind": variant["kind"], **_read_overrides(stages, VARIANT_STAGES, where)}
    return variants


def _unique_list(value, kind: type) -> bool:
    return (isinstance(value, list) and len(value) > 0 and all(isinstance(v, kind) and not isinstance(v, bool) for v in value)
            and len(set(value)) == len(value))
