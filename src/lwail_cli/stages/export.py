"""Stage: hand a policy to another toolkit (today: a Stable-Baselines3 TD3 model.zip that ``TD3.load`` reads)."""

from __future__ import annotations

from typing import TYPE_CHECKING

from ..errors import LwailError
from ..formats.sb3_zip import write_sb3_td3
from ..loaders import load_policy

if TYPE_CHECKING:
    from pathlib import Path

    from ..artifacts import Store

FORMATS = ("sb3",)


def export_policy(store: Store, *, policy_ref: str, fmt: str, out: Path) -> Path:
    if fmt not in FORMATS:
        raise LwailError(f"unknown export format {fmt!r} (known: {', '.join(FORMATS)})")
    policy = store.resolve(policy_ref, "policy")
    if out.suffix != ".zip":
        raise LwailError(f"{out}: an SB3 model is a .zip file")
    write_sb3_td3(load_policy(policy).state_dict(), tuple(policy.config["td3"]["hidden"]), policy.env.id, out)
    return out
