"""Property tests: compiled ray casts and wall contacts against brute-force references."""
import math

import numpy as np
from hypothesis import assume, given, settings
from hypothesis import strategies as st

from mahn_envs.core.geometry import cast_rays, sensor_directions, touches_any_wall, wall_boxes
from mahn_envs.maps import load_map

WORLD = load_map("plus")
WALLS = np.ascontiguousarray(WORLD.walls)
BOXES = wall_boxes(WALLS)
ANGLES = np.array([1.3398 - j * 0.53592 for j in range(6)])
RANGE = 16.66
DIRS = sensor_directions(ANGLES)

coord = st.floats(-10, 200, allow_nan=False)
heading = st.floats(-10, 10, allow_nan=False)


def brute_ray(cx, cy, a, walls, max_range):
    """Solve the 2x2 system for every wall with numpy, no bounding-box culling."""
    best = max_range
    d = np.array([math.cos(a) * max_range, math.sin(a) * max_range])
    for x1, y1, x2, y2 in walls:
        e = np.array([x2 - x1, y2 - y1])
        m = np.array([[d[0], -e[0]], [d[1], -e[1]]])
        if abs(np.linalg.det(m)) < 1e-12:
            continue
        r, s = np.linalg.solve(m, np.array([x1 - cx, y1 - cy]))
        if 0 < r < 1 and 0 < s < 1:
            best = min(best, r * max_range)
    return best


def brute_distance(cx, cy, walls, n=4001):
    """Distance to the walls by dense sampling of every wall."""
    t = np.linspace(0, 1, n)[:, None]
    best = np.inf
    for x1, y1, x2, y2 in walls:
        pts = np.array([x1, y1]) * (1 - t) + np.array([x2, y2]) * t
        best = min(best, np.hypot(pts[:, 0] - cx, pts[:, 1] - cy).min())
    return best


@settings(max_examples=300, deadline=None)
@given(coord, coord, heading)
def test_ray_cast_matches_brute_force(cx, cy, h):
    # a centre on a wall is physically impossible (radius 6.5) and numerically ambiguous for both sides
    assume(not touches_any_wall(cx, cy, 0.01, WALLS, BOXES))
    out = np.zeros(6)
    cast_rays(cx, cy, h, DIRS, RANGE, WALLS, BOXES, np.zeros((0, 2)), 0, 6.5, out, np.zeros(len(WALLS), np.int64))
    ref = [brute_ray(cx, cy, h + a, WALLS, RANGE) for a in ANGLES]
    assert np.allclose(out, ref, atol=1e-7)


@settings(max_examples=200, deadline=None)
@given(coord, coord, heading, coord, coord)
def test_ray_sees_a_robot_exactly_where_the_circle_is(cx, cy, h, qx, qy):
    out = np.zeros(6)
    others = np.array([[qx, qy]])
    cast_rays(cx, cy, h, DIRS, RANGE, np.zeros((0, 4)), np.zeros((0, 4)), others, 1, 6.5, out, np.zeros(0, np.int64))
    inside = math.hypot(qx - cx, qy - cy) <= 6.5
    for j, a in enumerate(ANGLES):
        ux, uy = math.cos(h + a), math.sin(h + a)
        if out[j] < RANGE:
            assert not inside
            px, py = cx + ux * out[j], cy + uy * out[j]
            assert abs(math.hypot(px - qx, py - qy) - 6.5) < 1e-6  # the hit lies on the circle
        # brute force: sample the ray, the first sample inside the circle is at or after the reported hit
        ts = np.linspace(0, RANGE, 3001)[1:]
        hit = np.hypot(cx + ux * ts - qx, cy + uy * ts - qy) < 6.5
        if not inside and hit.any():
            assert out[j] <= ts[np.argmax(hit)] + 1e-9


@settings(max_examples=300, deadline=None)
@given(coord, coord)
def test_wall_contact_matches_sampled_distance(cx, cy):
    d = brute_distance(cx, cy, WALLS)
    touching = touches_any_wall(cx, cy, 6.5, WALLS, BOXES)
    if d < 6.5 - 1e-3:
        assert touching
    elif d > 6.5 + 1e-3:
        assert not touching
