"""A replay buffer of preallocated tensors, sampled on the compute device.

On the CPU the tensors are written through numpy views of the same memory, so adding a transition
costs no tensor dispatch. On a GPU, transitions are staged in host memory and copied over in one
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
        self.storage = {name: torch.zeros(capacity, width, device=self.device) for name, width in widths.items()}
        on_cpu = self.device.type == "cpu"
        self._host = {
            name: tensor.numpy() if on_cpu else np.zeros((capacity, widths[name]), dtype=np.float32)
            for name, tensor in self.storage.items()
        }
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
        for name, tensor in self.storage.items():
            tensor[rows.to(self.device)] = torch.from_numpy(self._host[name][rows.numpy()]).to(self.device, non_blocking=True)
        self._pending_from = self.count

    def rows_since(self, count: int) -> np.ndarray:
        """Rows written since the buffer held ``count`` transitions (at most one full lap)."""
        first = max(count, self.count - self.capacity, 0)
        return np.arange(first, self.count) % self.capacity

    def sample(self, batch_size: int, generator: torch.Generator | None = None) -> dict[str, torch.Tensor]:
        self.flush()
        index = torch.randint(0, self.size, (batch_size,), device=self.device, generator=generator)
        return {name: tensor[index] for name, tensor in self.storage.items()}

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
