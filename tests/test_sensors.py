"""umbmark.model.sensors: the room, the lidar and the ray caster against closed-form ranges."""

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from umbmark.errors import InputError
from umbmark.model.sensors import ENGINES, Lidar, Room, SensorPose, cast_rays, have_numba

ENGINES_HERE = ["numpy"] + (["numba"] if have_numba() else [])


def rectangle_ranges(w, h, x, y, world_angles):
    """Closed form: the distance from (x, y) inside [0, w] x [0, h] to its walls along each angle."""
    c, s = np.cos(world_angles), np.sin(world_angles)
    with np.errstate(divide="ignore"):
        tx = np.where(c > 0, (w - x) / c, np.where(c < 0, -x / c, np.inf))
        ty = np.where(s > 0, (h - y) / s, np.where(s < 0, -y / s, np.inf))
    return np.minimum(tx, ty)


@pytest.mark.parametrize("engine", ENGINES_HERE)
@settings(max_examples=60, deadline=None)
@given(
    w=st.floats(0.5, 30.0),
    h=st.floats(0.5, 30.0),
    fx=st.floats(0.01, 0.99),
    fy=st.floats(0.01, 0.99),
    yaw=st.floats(-10.0, 10.0),
    n=st.integers(1, 50),
)
def test_rectangle_ranges_are_closed_form(engine, w, h, fx, fy, yaw, n):
    room = Room.rectangle(w, h)
    x, y = fx * w, fy * h
    angles = np.linspace(-math.pi, math.pi, n, endpoint=False) + 0.0123
    r = cast_rays(room, [x, y, yaw], angles, engine=engine)
    want = rectangle_ranges(w, h, x, y, yaw + angles)
    assert r.shape == (n,)
    np.testing.assert_allclose(r, want, rtol=1e-9, atol=1e-12)


@pytest.mark.parametrize("engine", ENGINES_HERE)
def test_many_poses_at_once_in_a_shifted_rectangle(engine):
    rng = np.random.default_rng(3)
    room = Room.rectangle(6.0, 4.0, x0_m=-2.0, y0_m=1.0)
    poses = np.column_stack([rng.uniform(-1.9, 3.9, 500), rng.uniform(1.1, 4.9, 500), rng.uniform(-4, 4, 500)])
    angles = Lidar(n_beams=90).angles_rad
    r = cast_rays(room, poses, angles, engine=engine)
    want = rectangle_ranges(6.0, 4.0, poses[:, 0:1] + 2.0, poses[:, 1:2] - 1.0, poses[:, 2:3] + angles)
    assert r.shape == (500, 90)
    np.testing.assert_allclose(r, want, rtol=1e-9)


@pytest.mark.parametrize("engine", ENGINES_HERE)
def test_a_beam_at_a_segment_end_hits_it_and_one_just_past_misses(engine):
    seg = np.array([[1.0, 0.0, 1.0, 1.0]])  # a lone wall from (1, 0) to (1, 1)
    angles = np.array([math.pi / 4, math.pi / 4 + 1e-7, 0.0, -1e-7, math.pi / 8])
    r = cast_rays(seg, [0.0, 0.0, 0.0], angles, engine=engine)
    assert r[0] == pytest.approx(math.sqrt(2.0), rel=1e-12)  # the far end
    assert r[1] == np.inf
    assert r[2] == pytest.approx(1.0, rel=1e-12)  # the near end
    assert r[3] == np.inf
    assert r[4] == pytest.approx(1.0 / math.cos(math.pi / 8), rel=1e-12)


@pytest.mark.parametrize("engine", ENGINES_HERE)
def test_walls_behind_parallel_or_beyond_range_give_no_return(engine):
    seg = np.array([[1.0, 0.0, 3.0, 0.0], [-5.0, -1.0, -5.0, 1.0]])
    # along the first wall (collinear: no hit), away from both, and toward the second at 5 m
    r = cast_rays(seg, [0.0, 0.0, 0.0], [0.0, math.pi / 2, math.pi], engine=engine)
    assert r[0] == np.inf and r[1] == np.inf
    assert r[2] == pytest.approx(5.0)
    assert cast_rays(seg, [0.0, 0.0, 0.0], [math.pi], max_range_m=4.9, engine=engine)[0] == np.inf


@pytest.mark.skipif(not have_numba(), reason="numba not installed")
def test_engines_agree_in_the_default_room():
    rng = np.random.default_rng(11)
    room = Room.default()
    poses = np.column_stack([rng.uniform(0.1, 9.9, 300), rng.uniform(0.1, 7.9, 300), rng.uniform(-4, 4, 300)])
    angles = Lidar().angles_rad
    a = cast_rays(room, poses, angles, 12.0, engine="numpy")
    b = cast_rays(room, poses, angles, 12.0, engine="numba")
    assert np.array_equal(np.isinf(a), np.isinf(b))
    fin = np.isfinite(a)
    np.testing.assert_allclose(a[fin], b[fin], rtol=1e-12)
    assert fin.mean() > 0.9


def test_the_nearest_wall_is_hit_through_the_obstacles():
    """A beam into the default room's pillar stops at its face; the box and stub walls block too."""
    room = Room.default()
    # the 0.4 m pillar at (2.6, 5.6): its right face at x = 2.8, seen from (5, 5.6) looking along -x
    assert cast_rays(room, [5.0, 5.6, math.pi], [0.0])[0] == pytest.approx(2.2)
    # the stub wall from the left wall at y = 2.6 (x 0 to 1.6), from (1.0, 1.0) looking along +y
    assert cast_rays(room, [1.0, 1.0, 0.0], [math.pi / 2])[0] == pytest.approx(1.6)
    # the cut corner: from (9, 7) along +x the wall x + y = 16.4 is at 0.4 m
    assert cast_rays(room, [9.0, 7.0, 0.0], [0.0])[0] == pytest.approx(0.4)


def test_distance_to_walls_and_contains():
    room = Room.rectangle(10.0, 8.0)
    pts = np.array([[5.0, 4.0], [0.3, 7.0], [9.0, 0.25]])
    np.testing.assert_allclose(room.distance_to_walls(pts), [4.0, 0.3, 0.25])
    # a point outside the room: its distance to the nearest wall (a corner)
    assert room.distance_to_walls([13.0, 12.0]) == pytest.approx(5.0)
    assert room.contains(pts).all() and not room.contains([10.5, 4.0])
    d = Room.default()
    assert d.contains([[5.0, 4.0], [9.0, 7.0]]).tolist() == [True, True]
    assert d.contains([[9.5, 7.5], [-0.1, 4.0], [5.0, 8.1]]).tolist() == [False, False, False]  # 9.5 + 7.5 > 16.4
    assert d.distance_to_walls([2.6, 5.0]) == pytest.approx(0.4)  # below the pillar's lower face at y = 5.4
    assert d.distance_to_walls([5.0, 4.0]) >= 1.5


@settings(max_examples=40, deadline=None)
@given(px=st.floats(-20, 20), py=st.floats(-20, 20))
def test_distance_to_walls_is_the_closest_point_of_a_fine_sampling(px, py):
    room = Room.default()
    u = np.linspace(0.0, 1.0, 2001)[:, None]
    s = room.segments
    pts = s[None, :, :2] + u[..., None] * (s[None, :, 2:] - s[None, :, :2])  # (U, N, 2)
    sampled = np.min(np.hypot(pts[..., 0] - px, pts[..., 1] - py))
    d = room.distance_to_walls([px, py])
    assert d <= sampled + 1e-12
    assert d >= sampled - 0.006  # the sampling is at most 3 mm coarse on the longest wall


def test_lidar_angles():
    full = Lidar(n_beams=360)
    assert full.angles_rad.shape == (360,)
    assert full.angle_increment_rad == pytest.approx(math.radians(1.0))
    assert full.first_angle_rad == pytest.approx(-math.pi)
    assert full.last_angle_rad == pytest.approx(math.pi - math.radians(1.0))
    part = Lidar(n_beams=271, fov_rad=math.radians(270))
    assert part.angles_rad[0] == pytest.approx(-math.radians(135))
    assert part.angles_rad[-1] == pytest.approx(math.radians(135))
    assert part.last_angle_rad == pytest.approx(part.angles_rad[-1])
    shifted = Lidar(n_beams=4, angle_min_rad=0.0)
    np.testing.assert_allclose(shifted.angles_rad, [0.0, math.pi / 2, math.pi, 3 * math.pi / 2])


def test_noise_statistics_and_dropouts():
    room = Room.rectangle(8.0, 6.0)
    lidar = Lidar(n_beams=180, range_noise_m=0.01, dropout_prob=0.1, max_range_m=20.0, min_range_m=0.0)
    poses = np.tile([3.0, 2.5, 0.4], (400, 1))
    exact = cast_rays(room, poses[0], lidar.angles_rad)
    r = lidar.scan(room, poses, rng=np.random.default_rng(5))
    n = r.size
    dropped = np.isinf(r)
    # dropouts: binomial(n, 0.1), within 5 standard deviations
    assert abs(dropped.sum() - 0.1 * n) < 5 * math.sqrt(n * 0.1 * 0.9)
    err = (r - exact)[~dropped]
    assert abs(err.mean()) < 5 * 0.01 / math.sqrt(err.size)
    assert err.std() == pytest.approx(0.01, rel=0.02)
    # Gaussian: about 4.55 % beyond two standard deviations
    assert np.mean(np.abs(err) > 0.02) == pytest.approx(0.0455, abs=0.004)


def test_range_limits():
    room = Room.rectangle(10.0, 2.0)
    lidar = Lidar(n_beams=4, angle_min_rad=0.0, max_range_m=5.0, min_range_m=0.3, range_noise_m=0.0)
    r = lidar.scan(room, [1.0, 0.2, 0.0])  # +x: 9 m (beyond), +y: 1.8 m, -x: 1 m, -y: 0.2 m (too close)
    assert r[0] == np.inf and r[3] == np.inf
    np.testing.assert_allclose(r[1:3], [1.8, 1.0])


def test_scans_are_reproducible_from_the_seed():
    room = Room.default()
    lidar = Lidar(range_noise_m=0.005, dropout_prob=0.02)
    poses = np.array([[5.0, 4.0, 0.0], [3.0, 2.0, 1.0]])
    a = lidar.scan(room, poses, rng=42)
    b = lidar.scan(room, poses, rng=np.random.default_rng(42))
    c = lidar.scan(room, poses, rng=43)
    assert np.array_equal(a, b)
    assert not np.array_equal(a, c)
    with pytest.raises(InputError, match="rng"):
        lidar.scan(room, poses)
    assert np.array_equal(Lidar(range_noise_m=0.0).scan(room, poses), cast_rays(room, poses, lidar.angles_rad, 12.0))


def _information(room, pose, lidar):
    """The point-to-line information of one scan about the sensor pose (x, y, yaw * 1 m)."""
    r = cast_rays(room, pose, lidar.angles_rad, lidar.max_range_m)
    ok = np.isfinite(r)
    a = pose[2] + lidar.angles_rad[ok]
    hit = np.column_stack([pose[0] + r[ok] * np.cos(a), pose[1] + r[ok] * np.sin(a)])
    s = room.segments
    e = s[:, 2:] - s[:, :2]
    u = np.clip(np.einsum("knj,nj->kn", hit[:, None] - s[None, :, :2], e) / np.einsum("nj,nj->n", e, e), 0, 1)
    gap = np.linalg.norm(hit[:, None] - (s[None, :, :2] + u[..., None] * e[None]), axis=2)
    wall = np.argmin(gap, axis=1)
    normal = np.column_stack([-e[wall, 1], e[wall, 0]]) / np.linalg.norm(e[wall], axis=1)[:, None]
    lever = hit - pose[:2]
    g = np.column_stack([normal, normal[:, 0] * -lever[:, 1] + normal[:, 1] * lever[:, 0]])
    return g.T @ g / ok.sum()


def test_the_default_room_fixes_x_y_and_yaw_everywhere_and_a_corridor_does_not():
    """Scan matching is well conditioned: every direction of the sensor pose moves many returns."""
    rng = np.random.default_rng(0)
    room, lidar = Room.default(), Lidar()
    poses = []
    while len(poses) < 60:
        p = np.array([rng.uniform(0, 10), rng.uniform(0, 8), rng.uniform(-math.pi, math.pi)])
        if room.contains(p[:2]) and room.distance_to_walls(p[:2]) >= 0.5:
            poses.append(p)
    worst = min(np.linalg.eigvalsh(_information(room, p, lidar))[0] for p in poses)
    assert worst > 0.05
    corridor = min(
        np.linalg.eigvalsh(_information(Room.rectangle(40.0, 2.0), np.array([20.0, 1.0, 0.2]), lidar))[0],
        1.0,
    )
    assert corridor < 1e-3  # along the corridor nothing within 12 m constrains x


def test_bad_inputs():
    with pytest.raises(InputError, match="shape"):
        Room(np.zeros((3, 3)))
    with pytest.raises(InputError, match="zero length"):
        Room(np.array([[0.0, 0.0, 0.0, 0.0]]))
    with pytest.raises(InputError, match="finite"):
        Room(np.array([[0.0, 0.0, np.nan, 1.0]]))
    with pytest.raises(InputError, match="width_m"):
        Room.rectangle(0.0, 1.0)
    for kw in (
        dict(n_beams=0),
        dict(fov_rad=7.0),
        dict(max_range_m=-1.0),
        dict(min_range_m=20.0),
        dict(range_noise_m=-0.1),
        dict(dropout_prob=1.0),
    ):
        with pytest.raises(InputError):
            Lidar(**kw)
    with pytest.raises(InputError, match="sensor_poses"):
        cast_rays(Room.default(), np.zeros((2, 2)), [0.0])
    with pytest.raises(InputError, match="engine"):
        cast_rays(Room.default(), [5, 4, 0], [0.0], engine="gpu")
    with pytest.raises(InputError, match="yaw_rad"):
        SensorPose(0.0, 0.0, math.inf)
    assert "numpy" in ENGINES


def test_sensor_pose_round_trip():
    p = SensorPose(0.1, -0.02, 0.3)
    assert SensorPose.from_array(p.as_array()) == p
    with pytest.raises(InputError):
        SensorPose.from_array([1.0, 2.0])
