"""Every hyper-parameter's one home: typed configs holding the paper's defaults (SPEC.md).

A config is recorded whole in the manifest of the artifact it produced, and any field can be
overridden from the CLI with ``--set section.field=value`` (e.g. ``--set td3.actor_lr=1e-4``).
"""

from __future__ import annotations

import dataclasses
import json
import typing
from dataclasses import dataclass, field

from .errors import LwailError


@dataclass(frozen=True)
class TD3Config:
    hidden: tuple[int, ...] = (256, 256)
    actor_lr: float = 3e-4
    critic_lr: float = 1e-3
    batch_size: int = 256
    gamma: float = 0.99
    tau: float = 0.005
    policy_delay: int = 2
    target_noise: float = 0.2  # times the action scale
    target_noise_clip: float = 0.5  # times the action scale
    exploration_noise: float = 0.1  # times the action scale
    buffer_size: int = 1_000_000
    random_steps: int = 10_000  # uniformly random actions before the actor acts
    learning_starts: int = 4_000  # env steps before the first gradient update


@dataclass(frozen=True)
class TrainConfig:
    """The schedule of an online TD3 run (an expert on the true reward, or LWAIL)."""

    steps: int = 1_000_000
    eval_every: int = 10_000
    eval_episodes: int = 10
    checkpoint_every: int = 50_000


@dataclass(frozen=True)
class ExpertConfig:
    td3: TD3Config = field(default_factory=TD3Config)
    train: TrainConfig = field(default_factory=TrainConfig)


@dataclass(frozen=True)
class ICVFConfig:
    steps: int = 10_000  # the authors train 200k; the probe plateaus far earlier (see README)
    batch_size: int = 256
    hidden: tuple[int, ...] = (256,)  # hidden widths of phi/psi before the embedding layer
    embedding_dim: int = 256
    ensemble: int = 2
    lr: float = 3e-4
    gamma: float = 0.99
    tau: float = 0.005
    expectile: float = 0.9
    p_goal_current: float = 0.2
    p_goal_trajectory: float = 0.5
    p_goal_random: float = 0.3
    p_outcome_is_goal: float = 0.5
    holdout_fraction: float = 0.1  # episodes kept out of training for the embedding-quality probe
    log_every: int = 500


@dataclass(frozen=True)
class DiscriminatorConfig:
    hidden: tuple[int, ...] = (64, 64)
    lr: float = 1e-3
    gp_weight: float = 10.0
    tanh: bool = False  # the authors wrap f in tanh inside the loss; the paper does not
    warmup_steps: int = 2_500
    warmup_transitions: int = 4_000
    update_every: int = 4_000
    update_steps: int = 40
    batch_size: int = 4_000


@dataclass(frozen=True)
class ImitationConfig:
    td3: TD3Config = field(default_factory=TD3Config)
    train: TrainConfig = field(default_factory=TrainConfig)
    disc: DiscriminatorConfig = field(default_factory=DiscriminatorConfig)
    expert_episodes: int = 1


def to_dict(config) -> dict:
    return dataclasses.asdict(config)


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
            return tuple(int(v) for v in text.replace(" ", "").strip("()[]").split(",") if v)
        if hint is int:
            return int(float(text)) if "e" in text.lower() else int(text)
        return hint(text)
    except ValueError:
        raise LwailError(f"--set {key}: cannot read {text!r} as {getattr(hint, '__name__', hint)}") from None


def with_overrides(config, assignments: list[str]):
    """Apply ``section.field=value`` assignments to a frozen config, checking names and types."""
    for assignment in assignments:
        key, sep, text = assignment.partition("=")
        if not sep:
            raise LwailError(f"--set expects section.field=value, got {assignment!r}")
        config = _replace_path(config, key.strip().split("."), text, key.strip())
    return config


def _replace_path(config, path: list[str], text: str, key: str):
    names = {f.name for f in dataclasses.fields(config)}
    if path[0] not in names:
        raise LwailError(f"--set {key}: unknown setting {path[0]!r}; known: {', '.join(sorted(names))}")
    hint = typing.get_type_hints(type(config))[path[0]]
    current = getattr(config, path[0])
    if len(path) > 1:
        if not dataclasses.is_dataclass(current):
            raise LwailError(f"--set {key}: {path[0]!r} has no sub-settings")
        value = _replace_path(current, path[1:], text, key)
    elif dataclasses.is_dataclass(current):
        raise LwailError(f"--set {key}: {path[0]!r} is a section; name one of its fields")
    else:
        value = _parse(text, hint, key)
    return dataclasses.replace(config, **{path[0]: value})


def describe(config) -> str:
    return json.dumps(to_dict(config), indent=2)
