"""A sweep plan's grids: each task × seed × embedding arm × method is a run (``SweepRun``), read from a plan's own
table or an [[also]] table (``read_grid``); an [axis] makes each arm one arm per value of a setting (``along_axis``).
The plan around them: ``sweep_plan.py``."""

from __future__ import annotations

from dataclasses import dataclass

from ..embeddings import EMBEDDINGS
from ..errors import LwailError
from ..methods import METHODS
from ..names import check_name, closest
from .declaration import FROM_GRID, holds

DEFAULT_METHODS = ("lwail",)
AXIS_KEYS = {"setting", "values", "name"}


@dataclass(frozen=True)
class SweepRun:
    task: str
    seed: int
    kind: str  # its embedding arm
    method: str | None = None  # its imitation method, where the plan names methods (None: LWAIL, named after its arm)

    @property
    def imitation(self) -> str:
        """The run's imitation method."""
        return self.method or DEFAULT_METHODS[0]

    @property
    def arm(self) -> str:
        """What the run's name ends with and the report groups by: the embedding arm, and the method where the plan names one."""
        return self.kind if self.method is None else f"{self.kind}-{self.method}"

    @property
    def label(self) -> str:
        return f"{self.task} seed {self.seed} {self.arm}"


@dataclass(frozen=True)
class Grid:
    """Every task × seed × embedding arm × method of it is a run."""

    tasks: tuple[str, ...]
    seeds: tuple[int, ...]
    kinds: tuple[str, ...]  # embedding arms: an embedding kind or a variant's name
    methods: tuple[str, ...] = DEFAULT_METHODS

    def runs(self, named: bool) -> list[SweepRun]:
        """``named``: the runs carry their method (the plan has other methods than LWAIL)."""
        return [SweepRun(task, seed, kind, method if named else None)
                for task in self.tasks for seed in self.seeds for kind in self.kinds for method in self.methods]

    def to_dict(self) -> dict:
        methods = {"methods": list(self.methods)} if self.methods != DEFAULT_METHODS else {}  # a plan of LWAIL alone records what it did before
        return {"tasks": list(self.tasks), "seeds": list(self.seeds), "embeddings": list(self.kinds), **methods}


def along_axis(axis, where: str, grids: tuple[Grid, ...], variants: dict, labels: dict, stages: tuple[str, ...]) -> tuple[tuple[Grid, ...], dict, dict]:
    """The grids, variants and labels with each arm made one variant per value of the axis's setting (given to every
    stage after collect whose config holds it, after the arm's own overrides)."""
    if not isinstance(axis, dict) or set(axis) - AXIS_KEYS or not {"setting", "values"} <= set(axis):
        raise LwailError(f"{where} needs setting = \"section.field\" and values = [...] (and may hold a short name)")
    setting, values = axis["setting"], axis["values"]
    if not isinstance(setting, str) or not isinstance(values, list) or not values or len(set(map(str, values))) != len(values):
        raise LwailError(f"{where}: 'setting' must name a setting as --set does, 'values' be a non-empty list of distinct values")
    if setting in {field for field, _ in FROM_GRID.values()}:
        raise LwailError(f"{where}: {setting!r} comes from the grid ('embeddings', 'methods'), not from an axis")
    short = axis.get("name", setting.rpartition(".")[2])
    if not isinstance(short, str):
        raise LwailError(f"{where}: 'name' must be a short text naming the axis in the arms' names")
    stages = [stage for stage in stages if holds(stage, setting)]
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
    grids = tuple(Grid(grid.tasks, grid.seeds, tuple(point for kind in grid.kinds for point in arms[kind]), grid.methods) for grid in grids)
    return grids, expanded, {arm: label for arm, label in labels.items() if arm in expanded}


def read_grid(table: dict, where: str, variants: dict, keys: set[str] | None = None) -> Grid:
    """tasks, seeds, embeddings (icvf and identity where not given) and methods (lwail where not given); ``keys``: the
    only keys the table may hold."""
    unknown = set(table) - keys if keys is not None else set()
    if unknown:
        raise LwailError(f"{where}: unknown keys {sorted(unknown)}; it may hold {sorted(keys)}")
    tasks, seeds, kinds = table.get("tasks"), table.get("seeds"), table.get("embeddings", ["icvf", "identity"])
    if not unique_list(tasks, str):
        raise LwailError(f"{where}: 'tasks' must be a non-empty list of distinct env ids")
    if not unique_list(seeds, int) or min(seeds) < 0 or max(seeds) >= 2**31:
        raise LwailError(f"{where}: 'seeds' must be a non-empty list of distinct integers in [0, 2^31)")
    if not unique_list(kinds, str):
        raise LwailError(f"{where}: 'embeddings' must be a non-empty list drawn from {list(EMBEDDINGS)} and the plan's [variants]")
    arms = [*EMBEDDINGS, *variants]
    unknown_arm = next((kind for kind in kinds if kind not in arms), None)
    if unknown_arm is not None:
        raise LwailError(f"{where}: unknown embedding {unknown_arm!r} in 'embeddings'; {closest(unknown_arm, arms, 'arms (embedding kinds and [variants])')}")
    methods = table.get("methods", list(DEFAULT_METHODS))
    if not unique_list(methods, str):
        raise LwailError(f"{where}: 'methods' must be a non-empty list of distinct methods drawn from {list(METHODS)}")
    unknown_method = next((method for method in methods if method not in METHODS), None)
    if unknown_method is not None:
        close = closest(unknown_method, list(METHODS), "methods")
        raise LwailError(f"{where}: unknown method {unknown_method!r} in 'methods'; the registered methods: {', '.join(METHODS)}"
                         + (f"; {close}" if close.startswith("did you mean") else ""))
    return Grid(tuple(tasks), tuple(seeds), tuple(kinds), tuple(methods))


def unique_list(value, kind: type) -> bool:
    return (isinstance(value, list) and len(value) > 0 and all(isinstance(v, kind) and not isinstance(v, bool) for v in value)
            and len(set(value)) == len(value))
