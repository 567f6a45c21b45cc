"""lwail: state-only imitation learning with LWAIL."""

from importlib.metadata import PackageNotFoundError, version

try:
    __version__ = version("lwail")
except PackageNotFoundError:  # running from a source tree that was never installed
    __version__ = "0.0.0+unknown"


def load_policy(ref, store=None, device="cpu"):
    """A trained policy with an SB3-style ``predict`` (see ``lwail_cli.api``); imported lazily, so ``import
    lwail_cli`` stays light."""
    from .api import load_policy as load

    return load(ref, store=store, device=device)
