"""The imitation methods, by name (`lwail imitate --method NAME`): a reward learner the TD3 loop runs, or a loop of
its own.

Every method is built from the same ``base.Inputs`` — the frozen embedding φ (the identity for raw states), the demo's
pair features ``[φ(s), φ(s') − φ(s)]``, the replay capacity. A reward learner (LWAIL, GAIfO, PWIL, DIFO: ``Method.build``)
becomes a ``base.Learner``: a ``training.RewardModel`` the loop asks for rewards (``prepare``), tells when an episode
ends, evaluates (``metrics``) and checkpoints (``state_dict``) without knowing which it is. A method with a loop of its
own (BCO, which clones a policy instead of rewarding TD3; OPOLO, TD3 with its own objective and inverse-dynamics model:
``Method.train``) gets the run's ``base.Session`` too and hands back the ``base.Trained`` policy; it plays, evaluates
and checkpoints through the same ``training.online_loop``.
So a method is one axis and the embedding another; every method shares the demo, the seed streams, the actor's format
and the evaluation (docs/algorithm.md, "Baselines in the same harness").

Adding a method: one module here with ``build(inputs) -> Learner`` (or ``train(inputs, session) -> Trained``) and
``METHOD = base.Method(...)``; its settings as one section of ``config.ImitationConfig`` and its name in
``config.METHODS``; its line in ``METHODS`` below; its tests (``tests/test_methods.py`` runs every entry end to end;
a numeric check of what it learns there or in its own file, e.g. ``tests/test_bco.py``).
"""

from __future__ import annotations

from .base import Inputs, Learner, Method, Session, Trained, Transitions  # noqa: F401
from . import bco, difo, gaifo, lwail, opolo, pwil

METHODS: dict[str, Method] = {method.name: method for method in (lwail.METHOD, gaifo.METHOD, pwil.METHOD, bco.METHOD, opolo.METHOD, difo.METHOD)}
