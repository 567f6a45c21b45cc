"""The PointMaze tasks (D4RL's maze2d): the flat observation, the fixed goal, the start and its seeded noise, the
planner expert, success-rate scoring, and the noise recorded in what a stage writes."""

import gymnasium as gym
import numpy as np
import pytest

from lwail_cli import config as cfg
from lwail_cli.envs import make_env
from lwail_cli.errors import LwailError
from lwail_cli.mazes import GOAL_RADIUS, MAZES, TASKS, cell_center, cell_of, open_cells
from lwail_cli.planner import MazePlanner, distances_to
from lwail_cli.rollout import rollout

UMAZE = "PointMazeUMaze-v0"
TINY = [[1, 1, 1, 1, 1],
        [1, 0, 0, 0, 1],
        [1, 1, 1, 0, 1],
        [1, 0, 0, 0, 1],
        [1, 1, 1, 1, 1]]  # a U: from (3, 1) to (1, 1) the path goes round the wall, never through it


def start(env_id=UMAZE, seed=0, noise=0.0):
    env = make_env(env_id, start_noise=noise)
    try:
        observation, _ = env.reset(seed=seed)
        return observation
    finally:
        env.close()


def test_the_observation_is_the_points_position_and_velocity_as_one_flat_box():
    env = make_env(UMAZE)
    try:
        assert isinstance(env.observation_space, gym.spaces.Box) and env.observation_space.shape == (4,)
        observation, _ = env.reset(seed=3)
        assert observation.shape == (4,) and np.array_equal(observation[:2], env.unwrapped.position)
        moved, *_ = env.step(np.array([1.0, 0.0], dtype=np.float32))
        assert moved[2] > observation[2]  # pushed along +x: the velocity is observed
    finally:
        env.close()


@pytest.mark.parametrize("env_id", [task for task in TASKS if "Sparse" not in task])
def test_every_maze_has_d4rls_fixed_goal_and_episode_length(env_id):
    maze = MAZES[TASKS[env_id][0]]
    env = make_env(env_id)
    try:
        goal = cell_center(maze.cells, maze.goal_cell)
        assert env.spec.max_episode_steps == maze.max_episode_steps == {"UMaze": 300, "Medium": 600, "Large": 800}[TASKS[env_id][0]]
        for seed in range(4):  # gymnasium-robotics would jitter the goal at every reset
            observation, _ = env.reset(seed=seed)
            assert np.array_equal(env.unwrapped.goal, goal) and np.array_equal(env.unwrapped._inner.goal, goal)
            _, reward, terminated, _, info = env.step(np.zeros(2, dtype=np.float32))
            distance = np.linalg.norm(env.unwrapped.position - goal)
            assert reward == pytest.approx(np.exp(-distance)) and not terminated and info["success"] == (distance <= GOAL_RADIUS)
    finally:
        env.close()


def test_the_sparse_variant_rewards_only_within_the_goal_radius():
    env = make_env("PointMazeUMazeSparse-v0")
    try:
        env.reset(seed=0)
        _, reward, _, _, info = env.step(np.zeros(2, dtype=np.float32))
        assert reward == float(info["success"])
    finally:
        env.close()


def test_episodes_start_in_random_open_cells_never_in_a_wall():
    cells = MAZES["Medium"].cells
    starts = {cell_of(cells, start("PointMazeMedium-v0", seed)[:2]) for seed in range(30)}
    assert len(starts) > 5 and starts <= set(open_cells(cells))


def test_start_noise_is_seeded_and_spreads_the_start():
    assert np.array_equal(start(seed=5, noise=0.5), start(seed=5, noise=0.5))  # same seed, same start
    assert not np.array_equal(start(seed=5, noise=0.5), start(seed=6, noise=0.5))
    quiet = np.array([start(seed=s)[2:] for s in range(20)])
    noisy = np.array([start(seed=s, noise=0.5)[2:] for s in range(20)])
    assert noisy.std() > 2 * quiet.std()  # velocity N(0, 0.1²) without, N(0, 0.1² + 0.5²) with
    cells = MAZES["UMaze"].cells
    assert all(cell_of(cells, start(seed=s, noise=0.5)[:2]) in open_cells(cells) for s in range(20))  # never in a wall


def test_bad_start_noise_is_one_clear_line():
    with pytest.raises(LwailError, match="env.start_noise must be at least 0"):
        cfg.with_overrides(cfg.EvalConfig(), ["env.start_noise=-0.1"])
    with pytest.raises(LwailError, match="PointMaze tasks only, not InvertedPendulum-v5"):
        make_env("InvertedPendulum-v5", start_noise=0.2)


def test_bfs_distances_go_round_the_wall_of_a_tiny_maze():
    distance = distances_to(TINY, (1, 1))
    assert distance[(3, 1)] == 6 and (2, 1) not in distance and set(distance) == set(open_cells(TINY))
    planner = MazePlanner(TINY, (1, 1), cell_center(TINY, (1, 1)))
    assert np.array_equal(planner.waypoint(cell_center(TINY, (3, 1))), cell_center(TINY, (3, 2)))  # away from the goal, round the wall
    assert np.array_equal(planner.waypoint(cell_center(TINY, (1, 2))), cell_center(TINY, (1, 1)))  # next to the goal: the goal


def test_the_planner_reaches_the_goal_and_success_is_scored():
    maze = MAZES["UMaze"]
    planner = MazePlanner(maze.cells, maze.goal_cell, cell_center(maze.cells, maze.goal_cell))
    played = rollout(UMAZE, planner, range(5), record=True)
    assert played.success_rate == 1.0 and played.returns.mean() > 100  # near the goal for most of its 300 steps
    idle = rollout(UMAZE, lambda obs: np.zeros((len(obs), 2), np.float32), range(5))
    started_at_goal = [np.linalg.norm(start(seed=s)[:2] - cell_center(maze.cells, maze.goal_cell)) <= GOAL_RADIUS for s in range(5)]
    assert list(idle.successes) == started_at_goal and idle.success_rate < 1.0
    assert rollout("InvertedPendulum-v5", None, range(2)).success_rate is None  # a task without success has no rate


def test_planner_demos_record_return_success_and_the_noise(cli, store):
    result = cli("demos", "import", "PointMazeUMaze-v0", "--planner", "--episodes", "2", "--start-noise", "0.2", "--name", "plan")
    assert result.exit_code == 0, result.output
    demos = store.resolve("plan", "demos")
    assert demos.metrics["success_rate"] == 1.0 and demos.metrics["mean_return"] > 100 and "success_rate=1" in result.output
    assert demos.config["env"] == {"start_noise": 0.2} and demos.config["source"] == "planner"
    assert cli("collect", UMAZE, "--transitions", "50", "--start-noise", "0.5", "--name", "data").exit_code == 0
    assert store.resolve("data", "dataset").config["env"] == {"start_noise": 0.5}
    refused = cli("demos", "import", "Hopper-v5", "--planner", "--episodes", "1")
    assert refused.exit_code != 0 and "--planner drives the PointMaze tasks" in refused.output
    refused = cli("collect", UMAZE, "--transitions", "50", "--start-noise", "-1")
    assert refused.exit_code != 0 and "env.start_noise must be at least 0" in refused.output
