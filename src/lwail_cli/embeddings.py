"""The embedding axis: every kind of state embedding φ is one entry of ``EMBEDDINGS``, which knows its settings (a
section of ``config.EmbedConfig``), how it is trained on data set I and how its artifact's record rebuilds it. The
stage (``stages/embed.py``), the loader (``loaders.load_encoder``), the command and the sweep's plan ask this
registry; none of them names a kind.

To add an embedding: its algorithm module (a ``pretrain_<kind>(episodes, obs_dim, config, seed, device, **loop) ->
pretraining.EmbeddingResult`` whose φ is a ``nets.embedding_net``, e.g. ``curl.py``), its settings (a config class
in config.py, its section of ``EmbedConfig`` named as the kind, the kind in ``config.EMBEDDING_KINDS``), its line
below, and its test (tests/test_embeddings.py).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Callable

from . import config as cfg
from .curl import pretrain_curl
from .errors import LwailError
from .icvf import pretrain_icvf
from .infonce import pretrain_infonce
from .nets import Encoder
from .pretraining import EmbeddingResult

PROBE_SECTION = "icvf"  # the identity is probed on the episodes ICVF holds out (icvf.holdout_fraction), so the two compare


@dataclass(frozen=True)
class Embedding:
    name: str
    settings_class: type | None  # None: nothing to train (the identity)
    pretrain: Callable[..., EmbeddingResult] | None

    @property
    def trained(self) -> bool:
        return self.settings_class is not None

    def settings(self, config: cfg.EmbedConfig):
        """This kind's section of the config (``config.<kind>``); None for the identity."""
        return getattr(config, self.name) if self.trained else None

    def own_section(self) -> str:
        """The section of ``EmbedConfig`` this kind reads."""
        return self.name if self.trained else PROBE_SECTION

    def record(self, config: cfg.EmbedConfig, obs_dim: int) -> dict:
        """What the artifact's manifest records: enough to rebuild φ (``encoder``)."""
        settings = self.settings(config)
        if settings is None:
            return {"type": self.name, "obs_dim": obs_dim, "embedding_dim": obs_dim}
        return {"type": self.name, "obs_dim": obs_dim, "embedding_dim": settings.embedding_dim, self.name: cfg.to_dict(settings)}

    def encoder(self, record: dict) -> Encoder:
        """φ's untrained shell for a ``record`` (the weights are the loader's to read)."""
        settings = cfg.from_dict(self.settings_class, record[self.name]) if self.trained else None
        return Encoder(record["obs_dim"], settings)


EMBEDDINGS: dict[str, Embedding] = {entry.name: entry for entry in (
    Embedding("icvf", cfg.ICVFConfig, pretrain_icvf),
    Embedding("identity", None, None),
    Embedding("infonce", cfg.InfoNCEConfig, pretrain_infonce),
    Embedding("curl", cfg.CURLConfig, pretrain_curl),
)}


def embedding(kind: str) -> Embedding:
    """The entry of ``kind`` (an artifact's recorded type, or ``embed.kind``)."""
    if kind not in EMBEDDINGS:
        raise LwailError(f"unknown embedding kind {kind!r} (this lwail knows {', '.join(EMBEDDINGS)})")
    return EMBEDDINGS[kind]


def unread_settings(config: cfg.EmbedConfig) -> list[str]:
    """The settings of other kinds' sections given away from their defaults: ones ``config.kind`` would ignore."""
    own = embedding(config.kind).own_section()
    defaults = cfg.EmbedConfig()
    changed = []
    for entry in EMBEDDINGS.values():
        section = entry.own_section()
        if entry.trained and section != own:
            given, default = cfg.to_dict(getattr(config, section)), cfg.to_dict(getattr(defaults, section))
            changed += [f"{section}.{key}" for key in given if given[key] != default[key]]
    return changed
