"""Stage: the learned reward of a critic drawn over its maze (`lwail reward-map`): a warmed-up discriminator, or the
online critic an `imitate` run kept, with the embedding φ it was trained on."""

from __future__ import annotations

from typing import TYPE_CHECKING

from ..errors import LwailError
from ..loaders import load_critic, load_encoder, load_weights, parent
from ..mazes import TASKS, cell_center, maze_of
from ..reward_map import plot_reward_map, reward_grid

if TYPE_CHECKING:
    from pathlib import Path

    from ..artifacts import Store

FILE = "reward-map.png"  # the default figure, beside the critic's artifact


def reward_map(store: Store, *, critic_ref: str, per_cell: int, out: Path | None = None) -> Path:
    """Draw σ(−f(φ(s), φ(s))) at zero velocity over the maze; ``critic_ref``: a discriminator or an imitation policy."""
    if per_cell < 2:
        raise LwailError(f"--per-cell must be at least 2 points per cell side, got {per_cell}")
    artifact = store.resolve_any(critic_ref)
    if artifact.kind not in ("discriminator", "policy"):
        raise LwailError(f"{artifact.ref} is a {artifact.kind}; reward-map draws a discriminator or an imitation policy's critic")
    maze = maze_of(artifact.env.id)
    if maze is None:
        raise LwailError(f"{artifact.ref} was made for {artifact.env.id}; reward-map draws the PointMaze tasks ({', '.join(TASKS)})")
    if artifact.kind == "policy" and "critic.safetensors" not in artifact.manifest["files"]:
        raise LwailError(f"{artifact.ref} holds no critic (an expert, not an `imitate` run)")
    disc = artifact if artifact.kind == "discriminator" else parent(store, artifact, "discriminator")
    embedding = parent(store, disc, "embedding")
    critic = load_critic(disc)
    if artifact.kind == "policy":
        load_weights(critic, artifact, "critic.safetensors")
    cells = maze.cells
    xs, ys, reward = reward_grid(load_encoder(embedding), critic.eval(), cells, per_cell)
    title = f"learned reward, {artifact.env.id}\n{artifact.ref} (φ: {embedding.config['type']})"
    return plot_reward_map(xs, ys, reward, cells, cell_center(cells, maze.goal_cell), out or artifact.beside(FILE), title)
