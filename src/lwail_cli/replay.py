"""A replay buffer of preallocated tensors, sampled on the compute device.

The fields are column blocks of one (capacity, width) table, so a batch is one gather of whole rows
(not one per field). On the CPU the table is written through a numpy view of the same memory, so adding
a transition costs no tensor dispatch. On a GPU, transitions are staged in host memory and copied over in one
block before the next sample.
"""

from __future__ import annotations

import numpy as np
import torch

FIELDS = ("observations", "actions", "next_observations", "rewards", "not_terminated")


class ReplayBuffer:
    def __init__(self, capacity: int, obs_dim: int, act_dim: int, device: torch.device | str = "cpu"):
        self.capacity = capacity
        self.device = torch.device(device)
        widths = {"observations": obs_dim, "actions": act_dim, "next_observations": obs_dim, "rewards": 1, "not_terminated": 1}
        self.table = torch.zeros(capacity, sum(widths.values()), device=self.device)
        self._columns = {}
        start = 0
        for name, width in widths.items():
            self._columns[name] = slice(start, start + width)
            start += width
        self.storage = {name: self.table[:, columns] for name, columns in self._columns.items()}  # views of the table
        self._host_table = self.table.numpy() if self.device.type == "cpu" else np.zeros(tuple(self.table.shape), dtype=np.float32)
        self._host = {name: self._host_table[:, columns] for name, columns in self._columns.items()}
        self._pending_from = 0  # first count not yet copied to the device (GPU only)
        self.count = 0  # transitions ever added; row of transition k is k % capacity

    @property
    def size(self) -> int:
        return min(self.count, self.capacity)

    def add(self, obs, action, reward: float, next_obs, terminated: bool) -> None:
        row = self.count % self.capacity
        host = self._host
        host["observations"][row] = obs
        host["actions"][row] = action
        host["next_observations"][row] = next_obs
        host["rewards"][row] = reward
        host["not_terminated"][row] = 0.0 if terminated else 1.0
        self.count += 1

    def flush(self) -> None:
        """Copy staged rows to the device (a no-op on the CPU)."""
        if self.device.type == "cpu" or self._pending_from == self.count:
            return
        rows = torch.from_numpy(self.rows_since(self._pending_from))
        self.table[rows.to(self.device)] = torch.from_numpy(self._host_table[rows.numpy()]).to(self.device, non_blocking=True)
        self._pending_from = self.count

    def rows_since(self, count: int) -> np.ndarray:
        """Rows written since the buffer held ``count`` transitions (at most one full lap)."""
        first = max(count, self.count - self.capacity, 0)
        return np.arange(first, self.count) % self.capacity

    def sample(self, batch_size: int, generator: torch.Generator | None = None) -> dict[str, torch.Tensor]:
        self.flush()
        index = torch.randint(0, self.size, (batch_size,), device=self.device, generator=generator)
        rows = self.table[index]
        return {name: rows[:, columns] for name, columns in self._columns.items()}

    def state_dict(self) -> dict:
        self.flush()
        return {"count": self.count, **{name: tensor[: self.size].cpu().clone() for name, tensor in self.storage.items()}}

    def load_state_dict(self, state: dict) -> None:
        self.count = int(state["count"])
        size = self.size
        for name, tensor in self.storage.items():
            tensor[:size] = state[name].to(self.device)
            if self.device.type != "cpu":
                self._host[name][:size] = state[name].numpy()
        self._pending_from = self.count
