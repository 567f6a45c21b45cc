"""The imitation methods, by name: the reward learner the TD3 loop runs (`lwail imitate --method NAME`).

Every method is built from the same ``base.Inputs`` — the frozen embedding φ (the identity for raw states), the demo's
pair features ``[φ(s), φ(s') − φ(s)]``, the replay capacity — into a ``base.Learner``: a ``training.RewardModel`` the
loop asks for rewards (``prepare``), tells when an episode ends, evaluates (``metrics``) and checkpoints
(``state_dict``) without knowing which it is. So a method is one axis and the embedding another; every method shares
TD3, the demo, the seed streams and the evaluation (docs/algorithm.md, "Baselines in the same harness").

Adding a method: one module here with ``build(inputs) -> Learner`` and ``METHOD = base.Method(...)``; its settings as
one section of ``config.ImitationConfig`` and its name in ``config.METHODS``; its line in ``METHODS`` below; its
tests in ``tests/test_methods.py`` (a numeric check of its reward, and the end-to-end run every entry gets there).
"""

from __future__ import annotations

from .base import Inputs, Learner, Method  # noqa: F401
from . import gaifo, lwail, pwil

METHODS: dict[str, Method] = {method.name: method for method in (lwail.METHOD, gaifo.METHOD, pwil.METHOD)}
