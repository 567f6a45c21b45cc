"""lwail: state-only imitation learning with LWAIL."""

from .version import __version__


def load_policy(ref, store=None, device="cpu"):
    """A trained policy with an SB3-style ``predict`` (see ``lwail_cli.api``); imported lazily, so ``import
    lwail_cli`` stays light."""
    from .api import load_policy as load

    return load(ref, store=store, device=device)


def load_embedding(ref, store=None):
    """φ of an embedding artifact as a numpy function (see ``lwail_cli.api``)."""
    from .api import load_embedding as load

    return load(ref, store=store)


def load_reward(ref, store=None):
    """A discriminator's reward σ(−f(φ(s), φ(s'))) as a numpy function (see ``lwail_cli.api``)."""
    from .api import load_reward as load

    return load(ref, store=store)


def load_episodes(ref, store=None):
    """A dataset's or demos' arrays: observations, episode_ends, terminations (see ``lwail_cli.api``)."""
    from .api import load_episodes as load

    return load(ref, store=store)
