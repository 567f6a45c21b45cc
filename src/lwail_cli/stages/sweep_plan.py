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
"""

from __future__ import annotations

import dataclasses
import tomllib
from dataclasses import dataclass, field
from pathlib import Path

from .. import config as cfg
from ..embeddings import EMBEDDINGS
from ..errors import LwailError
from ..names import check_name, closest
from .chain import CHAIN
from .demos import bundled_demos_path

PLAN_STAGES = (*CHAIN, "eval")
GRID_KEYS = {"tasks", "seeds", "embeddings"}
PLAN_KEYS = {"name", *GRID_KEYS, "also", "set", "variants", "threads", "labels", "axis"}
AXIS_KEYS = {"setting", "values", "name"}
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
class Grid:
    """Every task × seed × embedding arm of it is a run."""

    tasks: tuple[str, ...]
    seeds: tuple[int, ...]
    kinds: tuple[str, ...]  # embedding arms: an embedding kind or a variant's name

    @property
    def runs(self) -> list[SweepRun]:
        return [SweepRun(task, seed, kind) for task in self.tasks for seed in self.seeds for kind in self.kinds]

    def to_dict(self) -> dict:
        return {"tasks": list(self.tasks), "seeds": list(self.seeds), "embeddings": list(self.kinds)}


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
        return list(dict.fromkeys(run for grid in self.grids for run in grid.runs))

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

    def label(self, arm: str) -> str:
        return self.labels.get(arm, arm)

    def embedding_kind(self, arm: str) -> str:
        return self.variants[arm]["kind"] if arm in self.variants else arm

    def config(self, stage: str, arm: str | None = None):
        """The stage's validated config: defaults, the plan's overrides, the arm's variant overrides, and for
        pretrain-icvf the arm's embedding kind."""
        variant = self.variants.get(arm, {})
        fixed = [f"kind={self.embedding_kind(arm)}"] if stage == "pretrain-icvf" and arm is not None else []
        return cfg.with_overrides(cfg.STAGES[stage](), self.overrides.get(stage, ()), variant.get(stage, ()), fixed)

    def demos_name(self, task: str) -> str:
        return f"{self.name}-{task.lower()}-demos"

    def dataset_name(self, task: str, seed: int) -> str:
        return f"{self.name}-{task.lower()}-s{seed}-data"

    def names(self, run: SweepRun) -> dict[str, str]:
        """Each artifact's name, by kind."""
        base = f"{self.name}-{run.task.lower()}-s{run.seed}"
        return {"demos": self.demos_name(run.task), "dataset": self.dataset_name(run.task, run.seed), "embedding": f"{base}-{run.kind}",
                "discriminator": f"{base}-{run.kind}-disc", "policy": f"{base}-{run.kind}"}

    def to_dict(self) -> dict:
        also = {"also": [grid.to_dict() for grid in self.grids[1:]]} if len(self.grids) > 1 else {}
        labels = {"labels": dict(self.labels)} if self.labels else {}
        return {"name": self.name, **self.grids[0].to_dict(), **also, **labels,
                "set": {stage: list(assignments) for stage, assignments in self.overrides.items()},
                "variants": {name: {key: value if key == "kind" else list(value) for key, value in variant.items()}
                             for name, variant in self.variants.items()}, "threads": self.threads}


def grid_lines(plan: SweepPlan) -> list[str]:
    """The plan as it will run: its overrides, then each run with its embedding kind and its arm's own overrides."""
    lines = [f"[set] {stage}: {', '.join(assignments)}" for stage, assignments in plan.overrides.items()]
    for run in plan.runs:
        own = "; ".join(f"{stage}: {', '.join(assignments)}" for stage, assignments in plan.variants.get(run.kind, {}).items() if stage != "kind")
        lines.append(f"{run.label} ({plan.embedding_kind(run.kind)})" + (f"  {own}" if own else ""))
    return lines


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
    name = raw.get("name")
    if not isinstance(name, str):
        raise LwailError(f"{source}: 'name' must be a string naming the sweep")
    check_name(name)
    variants = _read_variants(raw.get("variants", {}), source)
    also = raw.get("also", [])
    if not isinstance(also, list) or not all(isinstance(table, dict) for table in also):
        raise LwailError(f"{source}: 'also' must be [[also]] tables, each with its own tasks, seeds and embeddings")
    grids = (_read_grid(raw, source, variants),
             *(_read_grid(table, f"{source}: [[also]] table {number}", variants, keys=GRID_KEYS) for number, table in enumerate(also, 1)))
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
        grids, variants, labels = _along_axis(raw["axis"], f"{source}: [axis]", grids, variants, labels)
    plan = SweepPlan(name, grids, _read_overrides(raw.get("set", {}), PLAN_STAGES, f"{source}: [set]"), variants, threads, labels)
    for task in plan.tasks:
        bundled_demos_path(task)  # refuses a task without bundled demos
    for stage in PLAN_STAGES:
        for arm in plan.kinds:
            plan.config(stage, arm)
    for run in plan.runs:
        for artifact_name in plan.names(run).values():
            check_name(artifact_name)
    return plan


def _along_axis(axis, where: str, grids: tuple[Grid, ...], variants: dict, labels: dict) -> tuple[tuple[Grid, ...], dict, dict]:
    """The grids, variants and labels with each arm made one variant per value of the axis's setting (given to every
    stage after collect whose config holds it, after the arm's own overrides)."""
    if not isinstance(axis, dict) or set(axis) - AXIS_KEYS or not {"setting", "values"} <= set(axis):
        raise LwailError(f"{where} needs setting = \"section.field\" and values = [...] (and may hold a short name)")
    setting, values = axis["setting"], axis["values"]
    if not isinstance(setting, str) or not isinstance(values, list) or not values or len(set(map(str, values))) != len(values):
        raise LwailError(f"{where}: 'setting' must name a setting as --set does, 'values' be a non-empty list of distinct values")
    short = axis.get("name", setting.rpartition(".")[2])
    if not isinstance(short, str):
        raise LwailError(f"{where}: 'name' must be a short text naming the axis in the arms' names")
    stages = [stage for stage in VARIANT_STAGES if _holds(stage, setting)]
    if not stages:
        raise LwailError(f"{where}: no stage after collect has the setting {setting!r}")
    expanded, arms = {}, {}
    for arm in dict.fromkeys(kind for grid in grids for kind in grid.kinds):
        base = variants.get(arm, {"kind": arm})
        for value in values:
            text = str(value).lower() if isinstance(value, bool) else str(value)
            point = f"{arm}-{short}{text}"
            check_name(point)
            extra = {stage: (*base.get(stage, ()), f"{setting}={text}") for stage in stages}
            expanded[point] = {**base, **extra}
            arms.setdefault(arm, []).append(point)
            if arm in labels:
                labels = {**labels, point: f"{labels[arm]}, {short} {text}"}
    grids = tuple(Grid(grid.tasks, grid.seeds, tuple(point for kind in grid.kinds for point in arms[kind])) for grid in grids)
    return grids, expanded, {arm: label for arm, label in labels.items() if arm in expanded}


def _holds(stage: str, setting: str) -> bool:
    """Whether the stage's config has the setting (``section.field``, as --set names it)."""
    node = cfg.STAGES[stage]()
    for part in setting.split("."):
        if not dataclasses.is_dataclass(node) or part not in {f.name for f in dataclasses.fields(node)}:
            return False
        node = vars(node)[part]
    return not dataclasses.is_dataclass(node)


def _read_grid(table: dict, where: str, variants: dict, keys: set[str] | None = None) -> Grid:
    """tasks, seeds and embeddings (icvf and identity where not given); ``keys``: the only keys the table may hold."""
    unknown = set(table) - keys if keys is not None else set()
    if unknown:
        raise LwailError(f"{where}: unknown keys {sorted(unknown)}; it may hold {sorted(keys)}")
    tasks, seeds, kinds = table.get("tasks"), table.get("seeds"), table.get("embeddings", ["icvf", "identity"])
    if not _unique_list(tasks, str):
        raise LwailError(f"{where}: 'tasks' must be a non-empty list of distinct env ids")
    if not _unique_list(seeds, int) or min(seeds) < 0 or max(seeds) >= 2**31:
        raise LwailError(f"{where}: 'seeds' must be a non-empty list of distinct integers in [0, 2^31)")
    if not _unique_list(kinds, str):
        raise LwailError(f"{where}: 'embeddings' must be a non-empty list drawn from {list(EMBEDDINGS)} and the plan's [variants]")
    arms = [*EMBEDDINGS, *variants]
    unknown_arm = next((kind for kind in kinds if kind not in arms), None)
    if unknown_arm is not None:
        raise LwailError(f"{where}: unknown embedding {unknown_arm!r} in 'embeddings'; {closest(unknown_arm, arms, 'arms (embedding kinds and [variants])')}")
    return Grid(tuple(tasks), tuple(seeds), tuple(kinds))


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
