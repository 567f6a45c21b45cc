"""The PointMaze tasks set up as D4RL's maze2d: gymnasium-robotics' point mass and maps, D4RL's fixed goal per maze,
a start in a random open cell, D4RL's episode lengths, and the observation D4RL gave (position and velocity, one
flat Box: the goal never moves, so it is not observed). ``start_noise`` adds seeded Gaussian noise of that std to the
initial state (the paper's navigation table). What follows D4RL and what departs: docs/algorithm.md, "Maze tasks".
"""

from __future__ import annotations

import contextlib
import importlib
import io
from dataclasses import dataclass

import gymnasium as gym
import numpy as np

GOAL_RADIUS = 0.5  # D4RL maze2d: the goal is reached within 0.5 of its centre (its sparse reward and success)
START_JITTER = 0.1  # D4RL maze2d's reset: uniform ±0.1 around the start cell's centre, velocity N(0, 0.1²)
NOISE_TRIES = 100  # draws of the start-state noise before falling back to the un-noised start (a position in a wall is redrawn)


@dataclass(frozen=True)
class Maze:
    """One of D4RL's maze2d layouts: its map (1 wall, 0 open) and its goal cell."""

    name: str  # gymnasium-robotics' name of the map
    goal_cell: tuple[int, int]  # (row, column) of D4RL's 'G'
    max_episode_steps: int  # D4RL's episode length for the maze

    @property
    def cells(self) -> list[list[int]]:
        maps = robotics("gymnasium_robotics.envs.maze.maps")
        return [[1 if cell == 1 else 0 for cell in row] for row in getattr(maps, self.name)]


MAZES = {  # lwail's task name -> the maze; D4RL's maze2d-umaze / -medium / -large layouts are gymnasium-robotics' maps
    "UMaze": Maze("U_MAZE", (1, 1), 300),
    "Medium": Maze("MEDIUM_MAZE", (6, 6), 600),
    "Large": Maze("LARGE_MAZE", (7, 9), 800),
}
REWARDS = {"": "dense", "Sparse": "sparse"}  # id suffix -> reward (dense: D4RL's maze2d-*-dense, exp(−distance))
TASKS = {f"PointMaze{name}{suffix}-v0": (name, reward) for name in MAZES for suffix, reward in REWARDS.items()}


def robotics(module: str):
    """A gymnasium-robotics module, imported on use (registering the ids stays cheap). Its first import prints a notice
    about its Adroit hand tasks to stderr (farama_notifications), which says nothing about the mazes: it is not shown."""
    with contextlib.redirect_stderr(io.StringIO()):
        return importlib.import_module(module)


def cell_center(cells: list[list[int]], cell: tuple[int, int]) -> np.ndarray:
    """The (x, y) of a cell's centre, as gymnasium-robotics lays a map out (unit cells, centred on the origin, rows going down)."""
    rows, columns = len(cells), len(cells[0])
    return np.array([cell[1] + 0.5 - columns / 2, rows / 2 - cell[0] - 0.5])


def cell_of(cells: list[list[int]], xy: np.ndarray) -> tuple[int, int]:
    rows, columns = len(cells), len(cells[0])
    return int(np.floor(rows / 2 - xy[1])), int(np.floor(xy[0] + columns / 2))


def is_open(cells: list[list[int]], cell: tuple[int, int]) -> bool:
    row, column = cell
    return 0 <= row < len(cells) and 0 <= column < len(cells[0]) and cells[row][column] == 0


def open_cells(cells: list[list[int]]) -> list[tuple[int, int]]:
    return [(row, column) for row, line in enumerate(cells) for column, cell in enumerate(line) if cell == 0]


def maze_of(env_id: str) -> Maze | None:
    task = TASKS.get(env_id)
    return None if task is None else MAZES[task[0]]


class D4RLPointMaze(gym.Env):
    """gymnasium-robotics' PointMaze with D4RL's maze2d conventions; ``info["success"]``: within ``GOAL_RADIUS``."""

    metadata = {"render_modes": ["rgb_array"], "render_fps": 50}

    def __init__(self, maze: str, reward: str = "dense", start_noise: float = 0.0, render_mode: str | None = None):
        self.maze = MAZES[maze]
        self.cells = self.maze.cells
        self.reward_type = reward
        self.start_noise = float(start_noise)
        self.render_mode = render_mode
        point_maze = robotics("gymnasium_robotics.envs.maze.point_maze")
        self._inner = point_maze.PointMazeEnv(maze_map=self.cells, reward_type=reward, continuing_task=True, reset_target=False,
                                              render_mode=render_mode)
        self.goal = cell_center(self.cells, self.maze.goal_cell)
        self.action_space = self._inner.action_space
        self.observation_space = gym.spaces.Box(-np.inf, np.inf, shape=(4,), dtype=np.float64)

    @property
    def model(self):  # the MuJoCo model and data, so a checkpoint captures the physics (resumable.EnvironmentState)
        return self._inner.point_env.model

    @property
    def data(self):
        return self._inner.point_env.data

    def reset(self, *, seed: int | None = None, options: dict | None = None):
        super().reset(seed=seed)
        self._inner.reset(seed=int(self.np_random.integers(2**31)))  # its own draws, made from ours
        self._inner.goal = self.goal.copy()  # D4RL's goal exactly (gymnasium-robotics jitters it)
        self._inner.update_target_site_pos()
        open_ = open_cells(self.cells)
        start = cell_center(self.cells, open_[int(self.np_random.integers(len(open_)))])
        position = start + self.np_random.uniform(-START_JITTER, START_JITTER, size=2)
        velocity = self.np_random.normal(0.0, START_JITTER, size=2)
        if self.start_noise > 0:
            position, velocity = self._noised(position, velocity)
        self._inner.point_env.set_state(position, velocity)
        return self._observation(), {"success": self._success()}

    def _noised(self, position: np.ndarray, velocity: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The state plus N(0, start_noise²) on each coordinate; a noised position inside a wall is drawn again."""
        for _ in range(NOISE_TRIES):
            noise = self.np_random.normal(0.0, self.start_noise, size=4)
            if is_open(self.cells, cell_of(self.cells, position + noise[:2])):
                return position + noise[:2], velocity + noise[2:]
        return position, velocity

    def step(self, action):
        _, _, _, _, info = self._inner.step(np.asarray(action, dtype=np.float64))
        distance = float(np.linalg.norm(self.position - self.goal))
        reward = np.exp(-distance) if self.reward_type == "dense" else float(distance <= GOAL_RADIUS)
        return self._observation(), float(reward), False, False, {"success": distance <= GOAL_RADIUS}

    @property
    def position(self) -> np.ndarray:
        return np.array(self._inner.point_env.data.qpos[:2])

    def _observation(self) -> np.ndarray:
        data = self._inner.point_env.data
        return np.concatenate([data.qpos[:2], data.qvel[:2]]).astype(np.float64)

    def _success(self) -> bool:
        return bool(np.linalg.norm(self.position - self.goal) <= GOAL_RADIUS)

    def render(self):
        return self._inner.render()

    def close(self):
        self._inner.close()


def register() -> None:
    for env_id, (maze, reward) in TASKS.items():
        if env_id not in gym.registry:
            gym.register(env_id, entry_point="lwail_cli.mazes:D4RLPointMaze", max_episode_steps=MAZES[maze].max_episode_steps,
                         kwargs={"maze": maze, "reward": reward})
