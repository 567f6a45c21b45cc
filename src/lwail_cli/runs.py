"""A long run's place in the store: claimed, resumed under the resume rule, checkpointed, cleared when done.

`expert train`, `imitate` and `pretrain-icvf` each open their run here; the algorithm inside hands its whole state
(``resumable.capture``) to ``Run.save_checkpoint`` and continues bit for bit from ``Run.resume``. A checkpoint
records what made the run (config, seed, env, parents); a resume under anything else is refused, except the
settings declared ``resume_may_change`` (the budget, and how the run is logged, evaluated and checkpointed).
"""

from __future__ import annotations

import signal
import threading
from contextlib import contextmanager
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Iterator

from . import config as cfg
from .errors import LwailError

if TYPE_CHECKING:
    from .artifacts import Artifact, Store


@dataclass(frozen=True)
class Run:
    store: Store
    kind: str
    name: str
    record: dict  # what made the run, saved in every checkpoint
    resume: dict | None  # the checkpoint the run continues from; None for a fresh run
    terminated: threading.Event = field(default_factory=threading.Event)  # SIGTERM came while the run was open

    def pause_requested(self) -> bool:
        """Whether the run was asked to checkpoint and stop: SIGTERM to its process, or `lwail pause`."""
        return self.terminated.is_set() or self.store.runs.take_pause_request(self.kind, self.name)

    def save_checkpoint(self, state: dict) -> None:
        self.store.runs.save_checkpoint(self.kind, self.name, {**state, "record": self.record})

    def write_log(self, filename: str, rows: list[dict]) -> None:
        """A CSV kept beside the checkpoint while the run goes on (what ``lwail curve`` shows of a live run)."""
        self.store.runs.write_run_log(self.kind, self.name, filename, rows)


def run_record(config: dict, seed: int, env_id: str, parents: list[Artifact]) -> dict:
    """What makes a run: the recorded config, the seed, the env and the hashes of the artifacts it reads."""
    return {"config": config, "seed": seed, "env": env_id, "parents": [p.hash for p in parents]}


@contextmanager
def open_run(store: Store, kind: str, name: str, *, resume: bool, record: dict, config_class: type,
             recorded_by_0_3: dict | None = None) -> Iterator[Run]:
    """Claim the run ``kind/name`` for this process (a fresh run never overwrites a killed run's checkpoint) and, with
    ``resume``, load its checkpoint, refused when made from another ``record`` than this one (or than
    ``recorded_by_0_3``, the same run as lwail 0.3 recorded it): only the settings of ``config_class`` declared
    ``resume_may_change`` may differ. The block writes the run's artifact; when it ends normally the checkpoint goes,
    when it raises the checkpoint stays for the next ``--resume``."""
    with store.runs.claim_run(kind, name, resume=resume):
        state = store.runs.load_checkpoint(kind, name) if resume else None
        if state is not None:
            may_change = cfg.resume_may_change(config_class)
            if recorded_by_0_3 is None or _changed(state["record"], recorded_by_0_3, may_change):
                _refuse_another_run(kind, name, state["record"], record, may_change)
        store.runs.take_pause_request(kind, name)  # asked of an earlier process of the run: not of this one
        run = Run(store, kind, name, record, state)
        with asked_on_signals(run.terminated, (signal.SIGTERM,)):
            yield run
        store.runs.clear_checkpoint(kind, name)


@contextmanager
def asked_on_signals(asked: threading.Event, signals: tuple[signal.Signals, ...]) -> Iterator[None]:
    """While the block runs, the first of ``signals`` sets ``asked`` (a run: checkpoint and stop where its loop next
    looks, within ~100 steps; a sweep: pause its runs) instead of killing the process; a second one acts as it would
    have. Only the main thread may set a handler: elsewhere the signals keep theirs."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    before = {signum: signal.getsignal(signum) for signum in signals}

    def ask(signum, frame) -> None:
        asked.set()
        for each, handler in before.items():
            signal.signal(each, handler)

    for signum in signals:
        signal.signal(signum, ask)
    try:
        yield
    finally:
        for signum, handler in before.items():
            signal.signal(signum, handler)


def _changed(recorded: dict, record: dict, may_change: tuple[str, ...]) -> list[str]:
    return [key for key in record if _what_trains(recorded.get(key), may_change) != _what_trains(record[key], may_change)]


def _refuse_another_run(kind: str, name: str, recorded: dict, record: dict, may_change: tuple[str, ...]) -> None:
    changed = _changed(recorded, record, may_change)
    if changed:
        # named only where the run records the setting's section (an embedding records its own kind's alone)
        recorded_here = [setting for setting in may_change if setting.partition(".")[0] in record["config"]]
        raise LwailError(
            f"the checkpoint of {kind}/{name} was made with another {' and '.join(changed)}; "
            f"rerun with the same options (only {', '.join(recorded_here)} may differ), or without --resume"
        )


def _what_trains(value, may_change: tuple[str, ...]):
    """A recorded value without the settings a resume may change (``section.field`` keys, at any depth)."""
    if not isinstance(value, dict):
        return value
    kept = {}
    for key, item in value.items():
        if key in may_change:
            continue
        inner = tuple(setting.partition(".")[2] for setting in may_change if setting.startswith(f"{key}."))
        kept[key] = _what_trains(item, inner) if inner else item
    return kept
