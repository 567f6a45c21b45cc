"""The learned reward over a maze, the paper's figure: σ(−f(φ(s), φ(s))) for the point standing still (zero velocity)
at each (x, y) of the open cells, the walls drawn over it, the goal marked."""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np
import torch

from .discriminator import transition_features
from .mazes import cell_center
from .plots import _pyplot, _save

if TYPE_CHECKING:
    from .discriminator import Critic


def reward_grid(encoder: torch.nn.Module, critic: Critic, cells: list[list[int]], per_cell: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """x and y (the grid's axes) and the reward at each point (rows follow y), NaN inside walls; ``per_cell``: points
    per cell side. The state is (x, y, 0, 0) and the pair (s, s): the reward for holding still there."""
    rows, columns = len(cells), len(cells[0])
    xs = (np.arange(columns * per_cell) + 0.5) / per_cell - columns / 2
    ys = rows / 2 - (np.arange(rows * per_cell) + 0.5) / per_cell
    grid_x, grid_y = np.meshgrid(xs, ys)
    states = np.stack([grid_x.ravel(), grid_y.ravel(), np.zeros(grid_x.size), np.zeros(grid_x.size)], axis=1)
    states = torch.as_tensor(states, dtype=torch.float32)
    with torch.no_grad():
        reward = torch.sigmoid(-critic(transition_features(encoder, states, states))).numpy().reshape(grid_x.shape)
    wall = np.kron(np.asarray(cells), np.ones((per_cell, per_cell))) == 1
    return xs, ys, np.where(wall, np.nan, reward)


def plot_reward_map(xs: np.ndarray, ys: np.ndarray, reward: np.ndarray, cells: list[list[int]], goal: np.ndarray,
                    path: Path, title: str) -> Path:
    plt = _pyplot()
    rows, columns = len(cells), len(cells[0])
    fig, ax = plt.subplots(figsize=(1 + 0.8 * columns, 0.8 * rows))
    extent = (xs[0] - 0.5 * (xs[1] - xs[0]), xs[-1] + 0.5 * (xs[1] - xs[0]), ys[-1] - 0.5 * (ys[0] - ys[1]), ys[0] + 0.5 * (ys[0] - ys[1]))
    image = ax.imshow(reward, extent=extent, origin="upper", cmap="viridis")
    for row, line in enumerate(cells):
        for column, cell in enumerate(line):
            if cell == 1:
                x, y = cell_center(cells, (row, column))
                ax.add_patch(plt.Rectangle((x - 0.5, y - 0.5), 1, 1, color="0.35"))
    ax.plot(*goal, marker="*", color="red", markersize=14, label="goal")
    ax.set(title=title, xlabel="x", ylabel="y", aspect="equal")
    ax.legend(loc="upper right", fontsize=8)
    fig.colorbar(image, ax=ax, label="σ(−f(φ(s), φ(s)))")
    _save(fig, path)
    return path
