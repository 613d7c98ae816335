import cv2
import numpy as np
import pytest
import yaml

from stereotrack.camera import Camera, Rig, intrinsics_from_fov, load_rig, look_at, rig_to_dict, save_rig, triangulate_points
from stereotrack.errors import StereotrackError


def make_rig(dist=None, n=2) -> Rig:
    cams = []
    K = intrinsics_from_fov(640, 480, 60.0)
    for i in range(n):
        eye = (-0.15 + 0.3 * i, 0.0 + 0.05 * i, 0.0)
        R, t = look_at(eye, (0.0, 0.0, 1.5))
        d = np.zeros(5) if dist is None else np.asarray(dist, float)
        cams.append(Camera(f"cam{i}", (640, 480), K, d, R, t))
    return Rig(tuple(cams))


DISTORTIONS = [
    [],
    [-0.28, 0.09, 0.001, -0.0005, -0.01],
    [-0.1, 0.02, 0.0005, 0.0002, 0.0, 0.01, 0.002, 0.0001],
    [-0.1, 0.02, 0.0005, 0.0002, 0.0, 0.01, 0.002, 0.0001, 0.001, -0.0005, 0.0008, 0.0002],
    [-0.1, 0.02, 0.0005, 0.0002, 0.0, 0.01, 0.002, 0.0001, 0.001, -0.0005, 0.0008, 0.0002, 0.01, -0.02],  # tilted sensor
]


def random_points(rng, n=500):
    return np.column_stack([rng.uniform(-0.5, 0.5, n), rng.uniform(-0.4, 0.4, n), rng.uniform(0.6, 3.0, n)])


@pytest.mark.parametrize("dist", DISTORTIONS)
def test_projection_matches_opencv(dist):
    rng = np.random.default_rng(1)
    rig = make_rig(dist)
    X = random_points(rng)
    for cam in rig.cameras:
        uv, ok = cam.project(X)
        assert ok.all()
        ref, _ = cv2.projectPoints(X, cv2.Rodrigues(cam.R)[0], cam.t, cam.K, cam.dist)
        assert np.abs(uv - ref.reshape(-1, 2)).max() < 1e-6


def test_points_behind_camera_are_flagged():
    rig = make_rig()
    uv, ok = rig[0].project(np.array([[0.0, 0.0, -1.0], [0.0, 0.0, 1.0]]))
    assert list(ok) == [False, True]
    assert np.isnan(uv[0]).all()


@pytest.mark.parametrize("dist", DISTORTIONS[:3])
def test_rays_pass_through_projected_points(dist):
    rng = np.random.default_rng(2)
    rig = make_rig(dist)
    X = random_points(rng)
    for cam in rig.cameras:
        uv, _ = cam.project(X)
        o, d = cam.rays(uv)
        assert np.allclose(np.linalg.norm(d, axis=1), 1.0)
        v = X - o
        perp = v - (v * d).sum(1, keepdims=True) * d
        assert np.linalg.norm(perp, axis=1).max() < 1e-6


@pytest.mark.parametrize("n_cams", [2, 3])
def test_triangulation_recovers_points(n_cams):
    rng = np.random.default_rng(3)
    rig = make_rig(DISTORTIONS[1], n=n_cams)
    X = random_points(rng, 200)
    pix = [cam.project(X)[0] for cam in rig.cameras]
    Y = triangulate_points(rig.cameras, pix)
    assert np.abs(Y - X).max() < 1e-6
    one = rig.triangulate([p[7] for p in pix])
    assert np.abs(one - X[7]).max() < 1e-6


def test_yaml_round_trip(tmp_path):
    rig = make_rig(DISTORTIONS[1])
    rig = Rig(rig.cameras, world="cam0", quality={"rms_px": 0.3})
    save_rig(rig, tmp_path / "c.yaml")
    back = load_rig(tmp_path / "c.yaml")
    assert back.names == rig.names and back.quality == {"rms_px": 0.3}
    for a, b in zip(rig.cameras, back.cameras):
        for f in ("K", "dist", "R", "t"):
            assert np.array_equal(getattr(a, f), getattr(b, f))
        assert a.image_size == b.image_size


def _write(tmp_path, data) -> str:
    p = tmp_path / "bad.yaml"
    p.write_text(yaml.safe_dump(data) if not isinstance(data, str) else data)
    return str(p)


@pytest.mark.parametrize(
    "mutate, field",
    [
        (lambda d: d["cameras"][0].pop("K"), "cameras[0].K"),
        (lambda d: d["cameras"][1].__setitem__("K", [[1, 0], [0, 1]]), "cameras[1].K"),
        (lambda d: d["cameras"][0].__setitem__("R", [[1, 0, 0], [0, 2, 0], [0, 0, 1]]), "cameras[0].R"),
        (lambda d: d["cameras"][0].__setitem__("t", [0, 0]), "cameras[0].t"),
        (lambda d: d["cameras"][0].__setitem__("dist", [0.1, 0.2, 0.3]), "cameras[0].dist"),
        (lambda d: d["cameras"][0].__setitem__("image_size", [640]), "cameras[0].image_size"),
        (lambda d: d.__setitem__("cameras", d["cameras"][:1]), "cameras"),
        (lambda d: d.__setitem__("world", "cam9"), "world"),
    ],
)
def test_bad_calibration_names_file_and_field(tmp_path, mutate, field):
    d = rig_to_dict(make_rig())
    mutate(d)
    path = _write(tmp_path, d)
    with pytest.raises(StereotrackError) as e:
        load_rig(path)
    assert path in str(e.value) and field in str(e.value)


def test_malformed_and_missing_calibration(tmp_path):
    with pytest.raises(StereotrackError, match="not valid YAML"):
        load_rig(_write(tmp_path, "cameras: [unclosed"))
    with pytest.raises(StereotrackError, match="not found"):
        load_rig(tmp_path / "nope.yaml")
    rig = make_rig()
    with pytest.raises(StereotrackError, match="no camera named 'cam7'"):
        rig["cam7"]


def test_rig_views_and_apparent_radius_agree_with_each_camera():
    from scene_helpers import default_rig

    rig = default_rig()
    pts = np.array([[0.0, 1.5, 0.0], [0.3, 2.5, 0.2], [0.0, -1.0, 0.0]])  # the last is behind both cameras
    uv, front, depth = rig.views(pts)
    assert uv.shape == (2, 3, 2) and front.shape == depth.shape == (2, 3)
    for c, cam in enumerate(rig.cameras):
        u, f = cam.project(pts)
        assert np.allclose(uv[c][f], u[f]) and np.array_equal(front[c], f)
        r = cam.apparent_radius(0.035, depth[c])
        assert np.allclose(r[f], cam.focal_px * 0.035 / cam.depth(pts)[f])


def test_a_centroid_uncertain_along_the_baseline_makes_the_triangulated_depth_uncertain_and_not_across():
    """Per-camera pixel covariances: sigma^2 I gives the isotropic figure; a centroid 4 pixels uncertain along the
    image's x (a streak along the epipolar lines) and half a pixel across makes the depth several times as uncertain,
    and the height (across it) no more so than before."""
    from stereotrack.camera import triangulate_with_covariance

    rig = make_rig()
    point = np.array([[0.05, 0.02, 2.0]])
    px = [cam.project(point)[0] for cam in rig.cameras]
    p0, iso = triangulate_with_covariance(rig.cameras, px, 0.5)
    same = [np.repeat((0.25 * np.eye(2))[None], 1, axis=0)] * 2
    p1, cov = triangulate_with_covariance(rig.cameras, px, 0.5, same)
    assert np.allclose(p0, p1) and np.allclose(iso, cov)
    along_x = [np.array([[[16.0, 0.0], [0.0, 0.25]]])] * 2
    _, streak = triangulate_with_covariance(rig.cameras, px, 0.5, along_x)
    ray = point[0] / np.linalg.norm(point[0])
    assert ray @ streak[0] @ ray > 20 * (ray @ iso[0] @ ray)
    assert streak[0][1, 1] < 1.5 * iso[0][1, 1]  # the height (the image's y: across the streak) keeps its figure
