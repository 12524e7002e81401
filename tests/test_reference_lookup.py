"""A long path's reference is looked up by bisection, built once: same samples as a scan of every segment."""

from __future__ import annotations

from itertools import pairwise

import numpy as np

from hil.scenario.reference import Patrol, Waypoints
from hil.scenario.reference.waypoints import smoothstep
from hil.scenario.schema import Scenario


def scanned(path: Waypoints, t: float) -> np.ndarray:
    """The position the slow way: walk every segment, keep the last that has started."""
    start, a, b, duration = 0.0, None, None, 1.0
    elapsed = 0.0
    points = [np.array(p, float) for p in path.points_ned]
    for p, q in pairwise(points):
        length = float(np.linalg.norm(q - p))
        seg = max(1.875 * length / path.speed, 1e-6)  # rest-to-rest quintic: peak speed 15/8 of the mean
        if a is None or t >= elapsed:
            start, a, b, duration = elapsed, p, q, seg
        elapsed += seg + path.dwell_s
    s, _, _ = smoothstep((t - start) / duration)
    return a + s * (b - a)


def test_a_long_path_samples_as_a_scan_of_every_segment():
    rng = np.random.default_rng(4)
    points = tuple(tuple(float(v) for v in p) for p in np.cumsum(rng.uniform(-5, 5, size=(200, 3)), axis=0))
    path = Waypoints(points, speed=3.0, dwell_s=0.5)
    for t in rng.uniform(-1.0, path.duration_s + 5.0, size=300):
        np.testing.assert_allclose(path.sample(float(t)).pos_ned, scanned(path, float(t)), atol=1e-9)


def test_a_patrol_builds_its_waypoints_once():
    patrol = Patrol((0.0, 0.0, 0.0), (40.0, 0.0, 0.0), passes=100)
    first = patrol.as_waypoints
    patrol.sample(10.0)
    assert patrol.as_waypoints is first


def test_a_route_of_two_thousand_waypoints_is_a_valid_scenario():
    points = [[float(i % 50), float(i // 50), -10.0] for i in range(2000)]
    scenario = Scenario.model_validate({"name": "route", "duration_s": 600,
                                        "reference": {"type": "waypoints", "points_ned": points, "speed": 5.0}})
    reference = scenario.reference.trajectory()
    assert reference.sample(1e6).pos_ned.tolist() == points[-1]  # past the end: the last point
