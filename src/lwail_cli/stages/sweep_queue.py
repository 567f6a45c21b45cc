"""The order in which a sweep hands its work to Ray: the plan's runs in the plan's order, as many at once as Ray's CPUs
hold. A φ being trained holds a CPU; a run waiting for its arm's φ holds none and is not given to Ray until the φ is
made (Ray starts ready tasks in no set order, and a run given early would hold a place while a core idles: with the
methods of an arm waiting for its φ, the driver used to leave the other core idle for the whole of φ's training).
No Ray here: the driver (``sweep.run_sweep``) asks what to start and says what ended."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Callable

from .sweep_grid import SweepRun

Arm = tuple[str, int, str]  # (task, seed, φ arm): what shares one φ


def arm_of(run: SweepRun) -> Arm:
    """Each embedding arm its own φ (a plan's ``phi_of`` lets arms that differ only after φ share one)."""
    return run.task, run.seed, run.kind


@dataclass
class RunQueue:
    waiting: list[SweepRun]  # not handed out yet, in the plan's order
    places: int  # runs and φs at once: Ray's CPUs over each one's threads
    phi_of: Callable[[SweepRun], Arm] = arm_of  # the φ a run reads
    parked: list[SweepRun] = field(default_factory=list)  # handed out, waiting for their arm's φ
    training: set[Arm] = field(default_factory=set)  # arms whose φ is being made
    made: set[Arm] = field(default_factory=set)  # arms whose φ is made (or failed: its runs then fail with its error)
    running: int = 0  # runs given to Ray and not ended

    def busy(self) -> int:
        return len(self.training) + self.running

    def take(self) -> tuple[list[Arm], list[SweepRun]]:
        """The φs to start and the runs to give Ray now: parked runs whose φ is made first, in order, then the plan's
        next runs while a place is free (a run whose φ is not made is parked, starting that φ if nothing has)."""
        phis: list[Arm] = []
        runs: list[SweepRun] = []
        for run in [run for run in self.parked if self.phi_of(run) in self.made]:
            if self.busy() >= self.places:
                break
            self.parked.remove(run)
            runs.append(run)
            self.running += 1
        while self.waiting and self.busy() < self.places:
            run = self.waiting.pop(0)
            arm = self.phi_of(run)
            if arm in self.made:
                runs.append(run)
                self.running += 1
                continue
            if arm not in self.training:
                self.training.add(arm)
                phis.append(arm)
            self.parked.append(run)
        return phis, runs

    def phi_made(self, arm: Arm) -> None:
        self.training.discard(arm)
        self.made.add(arm)

    def run_ended(self) -> None:
        self.running -= 1

    def unfinished(self) -> bool:
        return bool(self.waiting or self.parked or self.running or self.training)
