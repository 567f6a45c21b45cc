"""The maze expert, as D4RL generated maze2d: the shortest path over the maze's cells to the goal (breadth-first
search), followed by a PD controller toward the next cell's centre, then the goal (d4rl/pointmaze/waypoint_controller.py).

No training: the policy is a pure function of the observation (position, velocity), replanned at every step from
the cell the point is in, so it recovers wherever a push (or the start-state noise) leaves it.
"""

from __future__ import annotations

from collections import deque

import numpy as np

from .mazes import cell_center, cell_of, is_open

P_GAIN = 10.0  # D4RL's waypoint controller: action = P_GAIN·(waypoint − position) + D_GAIN·velocity, clipped to [−1, 1]
D_GAIN = -1.0
NEIGHBOURS = ((-1, 0), (1, 0), (0, -1), (0, 1))  # the point moves between cells that share a side


def distances_to(cells: list[list[int]], goal: tuple[int, int]) -> dict[tuple[int, int], int]:
    """Each open cell's number of moves to ``goal`` (breadth-first search from the goal); unreachable cells are absent."""
    distance = {goal: 0}
    frontier = deque([goal])
    while frontier:
        row, column = frontier.popleft()
        for d_row, d_column in NEIGHBOURS:
            neighbour = (row + d_row, column + d_column)
            if is_open(cells, neighbour) and neighbour not in distance:
                distance[neighbour] = distance[(row, column)] + 1
                frontier.append(neighbour)
    return distance


class MazePlanner:
    """The planner expert of one maze: a batch of observations (x, y, vx, vy) to a batch of actions."""

    def __init__(self, cells: list[list[int]], goal_cell: tuple[int, int], goal: np.ndarray):
        self.cells, self.goal_cell, self.goal = cells, goal_cell, np.asarray(goal, dtype=np.float64)
        self.distance = distances_to(cells, goal_cell)

    def waypoint(self, position: np.ndarray) -> np.ndarray:
        """The next cell's centre on a shortest path from the point's cell; the goal itself once in the goal's cell."""
        cell = cell_of(self.cells, position)
        if cell == self.goal_cell or cell not in self.distance:  # at the goal, or pushed into a wall's cell: head for the goal
            return self.goal
        row, column = cell
        following = min(((row + dr, column + dc) for dr, dc in NEIGHBOURS if (row + dr, column + dc) in self.distance),
                        key=lambda neighbour: self.distance[neighbour])
        return self.goal if following == self.goal_cell else cell_center(self.cells, following)

    def __call__(self, observations: np.ndarray) -> np.ndarray:
        observations = np.asarray(observations, dtype=np.float64)
        positions, velocities = observations[:, :2], observations[:, 2:4]
        waypoints = np.stack([self.waypoint(position) for position in positions])
        return np.clip(P_GAIN * (waypoints - positions) + D_GAIN * velocities, -1.0, 1.0).astype(np.float32)
