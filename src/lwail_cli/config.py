"""Every hyper-parameter's one home: a typed config per stage, validated when it is built.

Each field is declared with ``setting(default, doc, ...)``: the doc is the field's one-line comment (and
what ``lwail defaults STAGE`` prints beside it), the bounds are checked in ``__post_init__``, so a config
holding a bad value cannot exist and nothing is written before the check. A config is recorded whole in the
manifest of the artifact it produced; any field can be overridden from the CLI with
``--set section.field=value`` (e.g. ``--set td3.actor_lr=1e-4``). Defaults and their sources:
``docs/algorithm.md``.
"""

from __future__ import annotations

import dataclasses
import json
import math
import re
import typing
from dataclasses import dataclass, field

from .errors import LwailError


def setting(default, doc: str, *, low=None, high=None, below=None, choices=None, aliases=None):
    """A config field: its default, a one-line doc, and the bounds checked on every construction
    (``low``/``high`` inclusive, ``below`` exclusive, ``choices`` a set of allowed values). ``aliases`` maps
    values an older lwail recorded (or a plan still spells) to the value they mean now."""
    return field(default=default, metadata={"doc": doc, "low": low, "high": high, "below": below, "choices": choices,
                                            "aliases": aliases or {}})


def section(factory, doc: str):
    """A nested config (e.g. the TD3 settings inside the imitation config)."""
    return field(default_factory=factory, metadata={"doc": doc})


class Validated:
    """Checks every field's type and bounds after construction (and after each ``--set``)."""

    def __post_init__(self) -> None:
        hints = typing.get_type_hints(type(self))
        for f in dataclasses.fields(self):
            value = vars(self)[f.name]
            if isinstance(value, typing.Hashable) and value in f.metadata.get("aliases", {}):
                object.__setattr__(self, f.name, f.metadata["aliases"][value])  # frozen: the one place a field is rewritten
            _check(type(self).__name__, f, hints[f.name], vars(self)[f.name])
        self.check()

    def check(self) -> None:
        """Constraints between fields; a config overrides this (reading fields through ``vars``)."""


def _check(owner: str, f: dataclasses.Field, hint, value) -> None:
    name = f"{owner.removesuffix('Config').lower()}.{f.name}"
    if dataclasses.is_dataclass(hint):
        if not isinstance(value, hint):
            raise LwailError(f"{name} must be a {hint.__name__} section")
        return
    values = value if typing.get_origin(hint) is tuple else (value,)
    kind = typing.get_args(hint)[0] if typing.get_origin(hint) is tuple else hint
    if typing.get_origin(hint) is tuple and not isinstance(value, tuple):
        raise LwailError(f"{name} must be a tuple of {kind.__name__}s, got {value!r}")
    meta = f.metadata
    for item in values:
        if kind is bool and not isinstance(item, bool) or kind is int and (isinstance(item, bool) or not isinstance(item, int)):
            raise LwailError(f"{name} must be {kind.__name__}, got {item!r}")
        if kind is float:
            if isinstance(item, bool) or not isinstance(item, (int, float)):
                raise LwailError(f"{name} must be a number, got {item!r}")
            if not math.isfinite(item):
                raise LwailError(f"{name} must be finite, got {item!r}")
        if kind is str and not isinstance(item, str):
            raise LwailError(f"{name} must be text, got {item!r}")
        if meta.get("choices") is not None and item not in meta["choices"]:
            raise LwailError(f"{name} must be one of {', '.join(map(str, meta['choices']))}, got {item!r}")
        if meta.get("low") is not None and item < meta["low"]:
            raise LwailError(f"{name} must be at least {meta['low']}, got {item!r}")
        if meta.get("high") is not None and item > meta["high"]:
            raise LwailError(f"{name} must be at most {meta['high']}, got {item!r}")
        if meta.get("below") is not None and item >= meta["below"]:
            raise LwailError(f"{name} must be below {meta['below']}, got {item!r}")


MAX_STEPS = 100_000_000  # a budget past this is a typo, not a run (1M steps take ~1.5 h here)
LAYER_NORMS = ("none", "after", "before")  # where φ, ψ and T normalise: nets.StackedMLP
POLICY_NETWORKS = ("actor", "target", "average")  # TD3's online actor, its target actor, a slower average (train.average_tau)
# train keys a resumed run may change: its budget and how it is observed, none of which changes what it trains
# (evaluations use their own environments and no training randomness; tests/test_lwail.py checks it bit for bit)
RESUME_MAY_CHANGE = ("steps", "eval_every", "eval_episodes", "checkpoint_every", "average_tau")
MAX_BUFFER = 10_000_000  # replay rows: ~1 GiB per 10M rows of a 11-dim task, far more for Ant


# ------------------------------------------------------------------------------ shared sections
@dataclass(frozen=True)
class TD3Config(Validated):
    hidden: tuple[int, ...] = setting((256, 256), "hidden widths of the actor and of each twin critic", low=1, high=4096)
    actor_lr: float = setting(3e-4, "actor Adam learning rate", low=1e-7, high=1.0)
    critic_lr: float = setting(1e-3, "twin-critic Adam learning rate", low=1e-7, high=1.0)
    batch_size: int = setting(256, "transitions per TD3 update", low=1, high=65_536)
    gamma: float = setting(0.99, "discount factor", low=0.0, below=1.0)
    tau: float = setting(0.005, "Polyak rate of the target networks", low=0.0, high=1.0)
    policy_delay: int = setting(2, "critic updates per actor (and target) update", low=1, high=1000)
    target_noise: float = setting(0.2, "target-policy smoothing noise, times the action scale", low=0.0, high=10.0)
    target_noise_clip: float = setting(0.5, "clip of that noise, times the action scale", low=0.0, high=10.0)
    exploration_noise: float = setting(0.1, "Gaussian exploration noise, times the action scale", low=0.0, high=10.0)
    buffer_size: int = setting(1_000_000, "replay capacity (capped at the run's steps)", low=1, high=MAX_BUFFER)
    random_steps: int = setting(10_000, "uniformly random actions before the actor acts", low=0, high=MAX_STEPS)
    learning_starts: int = setting(4_000, "env steps before the first gradient update", low=1, high=MAX_STEPS)

    def check(self) -> None:
        starts, batch = vars(self)["learning_starts"], vars(self)["batch_size"]
        if starts < batch:
            raise LwailError(f"td3.learning_starts ({starts}) must be at least td3.batch_size ({batch})")


@dataclass(frozen=True)
class TrainConfig(Validated):
    """The schedule of an online TD3 run (an expert on the true reward, or LWAIL)."""

    steps: int = setting(1_000_000, "environment steps, one TD3 update each", low=1, high=MAX_STEPS)
    eval_every: int = setting(10_000, "evaluate the deterministic actor every this many env steps", low=1, high=MAX_STEPS)
    eval_episodes: int = setting(10, "episodes per evaluation", low=1, high=1000)
    checkpoint_every: int = setting(50_000, "checkpoint the whole run every this many env steps", low=1, high=MAX_STEPS)
    policy: str = setting("target", "the network evaluated and kept: target (the actor's Polyak average; docs/algorithm.md), actor (the online one) or average", choices=POLICY_NETWORKS)
    evaluate_other: bool = setting(True, "also evaluate the networks policy does not name on the same episodes (<name>_* columns)")
    average_tau: float = setting(0.0, "Polyak rate of a slower average of the actor, updated with the target (0: none); never feeds training", low=0.0, high=1.0)

    def check(self) -> None:
        if vars(self)["policy"] == "average" and vars(self)["average_tau"] == 0.0:
            raise LwailError("train.policy=average needs train.average_tau > 0 (e.g. 0.001)")


@dataclass(frozen=True)
class CriticConfig(Validated):
    """The discriminator f and its loss; fixed at warm-up, inherited by `imitate`."""

    hidden: tuple[int, ...] = setting((64, 64), "hidden widths of f (ReLU)", low=1, high=4096)
    lr: float = setting(1e-3, "Adam learning rate of f (warm-up and online updates)", low=1e-7, high=1.0)
    gp_weight: float = setting(10.0, "weight λ of the WGAN-GP gradient penalty", low=0.0, high=1e4)
    tanh: bool = setting(True, "loss on tanh f, as the authors' code (false: the paper's plain dual); the reward stays σ(−f)")


# ------------------------------------------------------------------------------ one config per stage
@dataclass(frozen=True)
class CollectConfig(Validated):
    transitions: int = setting(10_000, "uniformly random policy transitions to collect", low=1, high=MAX_BUFFER)


@dataclass(frozen=True)
class RecordConfig(Validated):
    episodes: int = setting(10, "episodes to record from the policy", low=1, high=10_000)


@dataclass(frozen=True)
class ExpertConfig(Validated):
    td3: TD3Config = section(TD3Config, "TD3 settings")
    train: TrainConfig = section(TrainConfig, "run schedule")


@dataclass(frozen=True)
class ICVFConfig(Validated):
    steps: int = setting(10_000, "gradient steps (the authors train 200k; see docs/algorithm.md)", low=1, high=MAX_STEPS)
    batch_size: int = setting(256, "(s, s', s+, z) tuples per gradient step", low=1, high=65_536)
    hidden: tuple[int, ...] = setting((256,), "hidden widths of φ, ψ and T before the embedding layer", low=1, high=4096)
    embedding_dim: int = setting(256, "dimension of φ(s)", low=1, high=4096)
    layer_norm: str = setting(
        "before", "LayerNorm in φ, ψ, T: none (the authors' PyTorch ICVF), after each GELU (the JAX ICVF's LayerNormMLP) "
        "or before it (lwail's own); docs/algorithm.md", choices=LAYER_NORMS, aliases={True: "before", False: "none", "true": "before", "false": "none"})
    ensemble: int = setting(2, "independent value functions (φ is taken from the first)", low=1, high=64)
    lr: float = setting(3e-4, "Adam learning rate", low=1e-7, high=1.0)
    gamma: float = setting(0.99, "discount of the intention-conditioned values", low=0.0, below=1.0)
    tau: float = setting(0.005, "Polyak rate of the target network", low=0.0, high=1.0)
    expectile: float = setting(0.9, "expectile of the value regression", low=0.0, high=1.0)
    p_goal_current: float = setting(0.2, "goal = the current state with this probability", low=0.0, high=1.0)
    p_goal_trajectory: float = setting(0.5, "goal = a later state of the same trajectory (else a random dataset state)", low=0.0, high=1.0)
    p_outcome_is_goal: float = setting(0.5, "outcome s+ = the goal z with this probability (else drawn anew)", low=0.0, high=1.0)
    holdout_fraction: float = setting(0.1, "episodes held out of training for the quality probe", low=0.0, below=1.0)
    log_every: int = setting(500, "log the loss and probe every this many steps", low=1, high=MAX_STEPS)
    checkpoint_every: int = setting(5_000, "checkpoint the pre-training every this many steps (resume: --resume)", low=1, high=MAX_STEPS)

    def check(self) -> None:
        trajectory_goals = vars(self)["p_goal_current"] + vars(self)["p_goal_trajectory"]
        if trajectory_goals > 1.0 + 1e-9:
            raise LwailError(
                f"icvf.p_goal_current + icvf.p_goal_trajectory must be at most 1 (the rest are random goals), got {trajectory_goals:g}"
            )


@dataclass(frozen=True)
class EmbedConfig(Validated):
    kind: str = setting("icvf", "icvf, or identity for the paper's no-embedding ablation", choices=("icvf", "identity"))
    icvf: ICVFConfig = section(ICVFConfig, "ICVF settings (unused by the identity)")


@dataclass(frozen=True)
class WarmupConfig(Validated):
    critic: CriticConfig = section(CriticConfig, "the discriminator f")
    steps: int = setting(2_500, "full-batch warm-up steps of f", low=1, high=MAX_STEPS)
    transitions: int = setting(4_000, "random-policy (s, s') pairs f is warmed up against", low=1, high=MAX_BUFFER)
    expert_episodes: int = setting(1, "expert trajectories used", low=1, high=10_000)


@dataclass(frozen=True)
class ImitationConfig(Validated):
    td3: TD3Config = section(TD3Config, "TD3 settings")
    train: TrainConfig = section(TrainConfig, "run schedule")
    update_every: int = setting(4_000, "train f (and relabel the buffer) every this many env steps", low=1, high=MAX_STEPS)
    update_steps: int = setting(40, "full-batch steps of f per update (paper: 40, authors' code: 30)", low=0, high=100_000)
    expert_episodes: int = setting(1, "expert trajectories to imitate", low=1, high=10_000)


@dataclass(frozen=True)
class EvalConfig(Validated):
    episodes: int = setting(10, "deterministic evaluation episodes", low=1, high=10_000)
    seed: int = setting(100, "seed of the first evaluation episode (the others count up)", low=0, high=2**31)


STAGES: dict[str, type] = {  # keyed by the command that takes the config
    "collect": CollectConfig,
    "expert-train": ExpertConfig,
    "expert-record": RecordConfig,
    "pretrain-icvf": EmbedConfig,
    "warmup-disc": WarmupConfig,
    "imitate": ImitationConfig,
    "eval": EvalConfig,
}


# ------------------------------------------------------------------------------ dicts and overrides
def to_dict(config) -> dict:
    """The config as plain data for a manifest (read through ``vars`` so recording is not "using")."""
    return {name: to_dict(value) if dataclasses.is_dataclass(value) else (list(value) if isinstance(value, tuple) else value)
            for name, value in vars(config).items()}


def from_dict(cls, data: dict):
    """Rebuild a (possibly nested) config from the dict stored in a manifest."""
    hints = typing.get_type_hints(cls)
    kwargs = {}
    for f in dataclasses.fields(cls):
        if f.name not in data:
            continue
        value = data[f.name]
        hint = hints[f.name]
        if dataclasses.is_dataclass(hint):
            value = from_dict(hint, value)
        elif typing.get_origin(hint) is tuple:
            value = tuple(value)
        kwargs[f.name] = value
    return cls(**kwargs)


def _parse(text: str, hint, key: str):
    try:
        if hint is bool:
            lowered = text.strip().lower()
            if lowered not in ("true", "false", "1", "0", "yes", "no"):
                raise ValueError(text)
            return lowered in ("true", "1", "yes")
        if typing.get_origin(hint) is tuple:
            return _parse_list(text)
        if hint is int:
            number = float(text) if "e" in text.lower() else int(text)
            if isinstance(number, float) and not number.is_integer():
                raise ValueError(text)
            return int(number)
        return hint(text)
    except (ValueError, OverflowError):
        raise LwailError(f"--set {key}: cannot read {text!r} as {getattr(hint, '__name__', hint)}") from None


_LIST = re.compile(r"\s*(?:\[(?P<square>[^][()]*)\]|\((?P<round>[^][()]*)\)|(?P<bare>[^][()]*))\s*")


def _parse_list(text: str) -> tuple[int, ...]:
    """``256,256``, ``[256, 256]`` or ``(256, 256)``, one trailing comma allowed (Python's ``(32,)``); ``[]``, ``()`` or
    nothing is the empty list (as widths: no hidden layer, a linear map). Anything else is refused, not guessed at:
    an unclosed bracket (``[32``), an empty item (``1,,2``), a space inside a number (``3 2``)."""
    match = _LIST.fullmatch(text)
    if match is None:
        raise ValueError(text)
    items = [item.strip() for item in next(group for group in match.groups() if group is not None).split(",")]
    if len(items) > 1 and items[-1] == "" and items[-2] != "":
        items.pop()
    if items == [""]:
        return ()
    return tuple(int(item) for item in items)  # int("") and int("3 2") raise ValueError


def with_overrides(config, *layers: list[str]):
    """Apply ``section.field=value`` assignments to a frozen config, all together: every name and value is read
    first, then each changed section is built (and checked) once, so a check across fields (td3.learning_starts
    against td3.batch_size) sees every assignment and their order never matters. Within a layer a key is given once;
    a later layer (a sweep variant's overrides after its plan's) overrides an earlier one."""
    changes: dict = {}
    for layer in layers:
        given: dict[str, object] = {}
        for assignment in layer:
            key, sep, text = assignment.partition("=")
            if not sep:
                raise LwailError(f"--set expects section.field=value, got {assignment!r}")
            key = key.strip()
            value = _read_setting(config, key.split("."), text, key)
            if key in given and given[key] != value:
                raise LwailError(f"--set {key} is given twice ({given[key]!r} and {value!r}); give it once")
            given[key] = value
            node = changes
            for part in key.split(".")[:-1]:
                node = node.setdefault(part, {})
            node[key.split(".")[-1]] = value
    return _rebuilt(config, changes)


def _read_setting(config, path: list[str], text: str, key: str):
    """The value ``text`` gives the setting at ``path`` (its name and type checked; its bounds when the config is built)."""
    names = {f.name for f in dataclasses.fields(config)}
    if path[0] not in names:
        raise LwailError(f"--set {key}: unknown setting {path[0]!r}; known: {', '.join(sorted(names))}")
    current = vars(config)[path[0]]
    if len(path) > 1:
        if not dataclasses.is_dataclass(current):
            raise LwailError(f"--set {key}: {path[0]!r} has no sub-settings")
        return _read_setting(current, path[1:], text, key)
    if dataclasses.is_dataclass(current):
        raise LwailError(f"--set {key}: {path[0]!r} is a section; name one of its fields")
    return _parse(text, typing.get_type_hints(type(config))[path[0]], key)


def _rebuilt(config, changes: dict):
    """``config`` with ``changes`` (nested dicts for sections), each changed section built once, innermost first."""
    if not changes:
        return config
    return dataclasses.replace(config, **{
        name: _rebuilt(vars(config)[name], value) if dataclasses.is_dataclass(vars(config)[name]) else value
        for name, value in changes.items()
    })


def describe(config, indent: str = "") -> str:
    """Each setting with its default and its one-line doc, as ``--set`` names it."""
    lines = []
    for f in dataclasses.fields(config):
        value = vars(config)[f.name]
        if dataclasses.is_dataclass(value):
            lines.append(f"{indent}{f.name}:  # {f.metadata['doc']}")
            lines.append(describe(value, indent + "  "))
        else:
            shown = json.dumps(list(value) if isinstance(value, tuple) else value)
            lines.append(f"{indent}{f.name} = {shown}  # {f.metadata['doc']}")
    return "\n".join(lines)
