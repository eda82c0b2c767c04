"""Chapter 5's readings of Eq. 6's factor.

Chapter 5 puts the gripper at the origin and reads the goal-oriented factor lambda_r
(`rewards.goal_oriented_factor`, Eq. 6) on hand-made actions: `action` turns a unit
gripper displacement by an azimuth and an elevation, `rotated_actions` scores it turned
round the horizontal plane (the line of the chapter's figure), `random_actions` scores
actions drawn uniformly from the action box (the dots and the histogram) beside their
angle to the goal, and `corner_factors` scores the directions of two corners of that
box (`CORNERS`). The figures of them: `plots.factor_curve`,
`plots.factor_minibatch` and `plots.factor_against_block`.

Trap: uniform actions fill a cube, not a sphere, so their directions are not uniform:
the histogram of their factors peaks near the corners' factors, though the mean stays
1.25 by symmetry.
"""

from __future__ import annotations

import numpy as np

from acder_lite.algo.rewards import goal_oriented_factor

CORNERS = np.array([[1, 1, 1, 0], [-1, 1, 1, 0]])
"""Two actions at corners of the action box, one leaning towards a goal along +x, one
away from it (the gripper component last, 0)."""


def _from_origin(goal, u) -> np.ndarray:
    """Eq. 6 of each action of `u` towards `goal`, the gripper at the origin."""
    k = len(u)
    return goal_oriented_factor(np.zeros((k, 3)), np.tile(goal, (k, 1)), u)


def action(azimuth_deg: float, elevation_deg: float) -> np.ndarray:
    """A unit gripper displacement turned `azimuth_deg` from +x in the horizontal plane
    and `elevation_deg` up from it, as a 4-component action (the gripper's own
    component 0)."""
    az, el = np.radians(azimuth_deg), np.radians(elevation_deg)
    return np.array([np.cos(el) * np.cos(az), np.cos(el) * np.sin(az), np.sin(el), 0.0])


def rotated_actions(goal, azimuth=None) -> dict:
    """Eq. 6 of a horizontal unit action (`action`, elevation 0) at each of `azimuth`
    (degrees; by default -180 to 180 in steps of 1), the gripper at the origin and
    `goal` ahead of it along +x: {"angle": |azimuth| (the angle to the goal), "lam"}."""
    az = np.linspace(-180, 180, 361) if azimuth is None else np.asarray(azimuth)
    lam = _from_origin(goal, np.stack([action(a, 0) for a in az]))
    return dict(angle=np.abs(az), lam=lam)


def angle_to_goal(goal, u) -> np.ndarray:
    """The angle (degrees) between the gripper part of each action of `u` (its first 3
    components) and the direction to `goal` from the gripper at the origin."""
    d = np.asarray(goal, np.float64) / np.linalg.norm(goal)
    a = np.asarray(u, np.float64)[:, :3]
    cos = np.sum(a * d, axis=-1) / np.linalg.norm(a, axis=1)
    return np.degrees(np.arccos(np.clip(cos, -1.0, 1.0)))


def random_actions(goal, n: int, rng) -> dict:
    """`n` actions drawn uniformly from the action box [-1, 1]^4 with `rng` (one draw of
    shape (n, 4)), the gripper at the origin: {"u": the actions, "lam": Eq. 6 of each
    towards `goal`, "angle": each one's `angle_to_goal`}."""
    u = rng.uniform(-1, 1, (n, 4))
    return dict(u=u, lam=_from_origin(goal, u), angle=angle_to_goal(goal, u))


def corner_factors(goal) -> np.ndarray:
    """Eq. 6 of the `CORNERS` directions towards `goal`, the gripper at the origin:
    for a goal along +x, 1 + arccos(1/sqrt(3)) / (2 pi) and 1 + arccos(-1/sqrt(3)) /
    (2 pi)."""
    return _from_origin(goal, CORNERS)
