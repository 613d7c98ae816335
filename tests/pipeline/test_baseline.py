"""The classic OpenCV pipeline: exact triangulation, real table-tennis detections, end to end on drawn frames."""

from pathlib import Path

import cv2
import numpy as np
import pytest

from stereotrack.camera import Camera, Rig, intrinsics_from_fov, look_at, triangulate_points
from stereotrack.config import config_from_dict
from stereotrack.errors import StereotrackError
from stereotrack.frames import FramePair
from stereotrack.pipeline.baseline import (
    BaselineTracker,
    epipolar_distances,
    fundamental_matrix,
    ideal_pixels,
    match_epipolar,
    triangulate_pairs,
)

DATA = Path(__file__).parents[1] / "data" / "tabletennis-2cam"
DIST = np.array([-0.28, 0.09, 0.001, -0.0005, -0.01])
GREEN = {"name": "green", "hsv_min": [50, 120, 80], "hsv_max": [70, 255, 255], "radius": 0.035}


def stereo_rig(dist=DIST) -> Rig:
    """Two 640x480 cameras 30 cm apart (along world x) looking at a point 1.5 m ahead."""
    K = intrinsics_from_fov(640, 480, 60.0)
    cams = []
    for i, x in enumerate((-0.15, 0.15)):
        R, t = look_at((x, 0.0, 0.0), (0.0, 0.0, 1.5))
        cams.append(Camera(f"cam{i}", (640, 480), K, np.asarray(dist, float), R, t))
    return Rig(tuple(cams))


def test_fundamental_matrix_holds_for_projected_points():
    rng = np.random.default_rng(0)
    rig = stereo_rig()
    X = np.column_stack([rng.uniform(-0.4, 0.4, 50), rng.uniform(-0.3, 0.3, 50), rng.uniform(0.8, 2.5, 50)])
    pa, pb = (ideal_pixels(cam, cam.project(X)[0]) for cam in rig.cameras)
    F = fundamental_matrix(rig[0], rig[1])
    d = epipolar_distances(F, pa, pb)
    assert np.abs(np.diag(d)).max() < 1e-6
    # Distinct random points are (almost always) far from each other's epipolar lines.
    assert np.median(d[~np.eye(50, dtype=bool)]) > 10


def test_triangulates_exact_detections_to_a_micrometre():
    """Points seen through distorting lenses, centroids exact: cv2.triangulatePoints on undistorted points recovers them to 1e-6 m."""
    rng = np.random.default_rng(1)
    rig = stereo_rig()
    X = np.column_stack([rng.uniform(-0.4, 0.4, 200), rng.uniform(-0.3, 0.3, 200), rng.uniform(0.6, 3.0, 200)])
    pa, pb = (cam.project(X)[0] for cam in rig.cameras)
    Y = triangulate_pairs(rig[0], rig[1], pa, pb)
    assert np.abs(Y - X).max() < 1e-6
    assert np.abs(Y - triangulate_points(rig.cameras, [pa, pb])).max() < 1e-6


def test_detections_to_objects_pairs_and_triangulates_several_balls():
    """Five balls of one colour, blob lists shuffled per camera: every ball is paired and placed to 1e-6 m."""
    rng = np.random.default_rng(2)
    rig = stereo_rig()
    X = np.array([[-0.3, -0.2, 1.2], [0.0, -0.1, 1.5], [0.25, 0.0, 1.8], [-0.1, 0.12, 1.1], [0.2, 0.22, 2.2]])
    pa, pb = (cam.project(X)[0] for cam in rig.cameras)
    pb = pb[rng.permutation(5)]
    tracker = BaselineTracker(rig, config_from_dict({"targets": [GREEN]}))
    objects, rays = tracker.detections_to_objects({"green": (pa, pb)})
    assert len(objects) == 5 and len(rays) == 2
    found = np.array([o.position for o in objects])
    err = np.linalg.norm(found[:, None] - X[None], axis=2).min(axis=0)
    assert err.max() < 1e-6
    # Covariance: positive definite, widest along the viewing direction (depth), about a millimetre per pixel laterally.
    for o in objects:
        w, v = np.linalg.eigh(o.covariance)
        assert w.min() > 0
        view = o.position - rig[0].centre
        assert abs(v[:, -1] @ view) / np.linalg.norm(view) > 0.9
        assert 2e-4 < np.sqrt(w[-1]) < 0.05


def test_pairs_beyond_the_epipolar_gate_or_behind_the_cameras_are_dropped():
    rig = stereo_rig(dist=[])
    F = fundamental_matrix(rig[0], rig[1])
    X = np.array([[0.0, 0.0, 1.5]])
    pa, pb = (cam.project(X)[0] for cam in rig.cameras)
    ia, ib = match_epipolar(F, pa, pb + [0.0, 10.0], max_px=4.0)  # 10 px off the epipolar line: no pair
    assert len(ia) == 0
    ia, ib = match_epipolar(F, pa, pb + [0.0, 3.0], max_px=4.0)
    assert list(ia) == [0] and list(ib) == [0]
    # Two rays that meet behind the cameras: the pair is epipolar-consistent but not a ball.
    tracker = BaselineTracker(rig, config_from_dict({"targets": [GREEN]}))
    behind = np.array([[0.0, 0.0, -1.5]])
    qa = rig[0].distort_normalised((behind @ rig[0].R.T + rig[0].t)[:, :2] / (behind @ rig[0].R.T + rig[0].t)[:, 2:])
    qb = rig[1].distort_normalised((behind @ rig[1].R.T + rig[1].t)[:, :2] / (behind @ rig[1].R.T + rig[1].t)[:, 2:])
    objects, _ = tracker.detections_to_objects({"green": (qa, qb)})
    assert objects == ()


# --------------------------------------------------------------------------- real table-tennis detections

# World points (metres) of camera 1's six keypoints in its stored order; camera 2 lists them as [2, 3, 0, 1, 5, 4].
TABLE_POINTS = np.array([(0, 1.525, 0), (2.74, 1.525, 0), (2.74, 0, 0), (0, 0, 0), (1.37, -0.1525, 0.15), (1.37, 1.6775, 0.15)])
# The keypoints' world frame is left-handed as seen by these cameras (a DLT fit puts the table behind
# them); mirroring y makes it a real camera pose and leaves heights (z) unchanged.
MIRROR_Y = np.diag([1.0, -1.0, 1.0])


def dlt_projection(world: np.ndarray, pixels: np.ndarray) -> np.ndarray:
    """3x4 projection from >= 6 world/pixel pairs by the direct linear transform."""
    rows = []
    for (x, y, z), (u, v) in zip(world, pixels):
        rows.append([x, y, z, 1, 0, 0, 0, 0, -u * x, -u * y, -u * z, -u])
        rows.append([0, 0, 0, 0, x, y, z, 1, -v * x, -v * y, -v * z, -v])
    return np.linalg.svd(np.asarray(rows))[2][-1].reshape(3, 4)


def camera_from_projection(name: str, P: np.ndarray, size: tuple[int, int]) -> Camera:
    if np.linalg.det(P[:, :3]) < 0:
        P = -P
    K, R, C = cv2.decomposeProjectionMatrix(P)[:3]
    K = K / K[2, 2]
    D = np.diag(np.sign(np.diag(K)))  # RQ may return negative focal lengths: move the signs into R
    K, R = K @ D, D @ R
    C = C[:3, 0] / C[3, 0]
    return Camera(name, size, K, np.zeros(0), R, -R @ C)


@pytest.fixture(scope="module")
def tabletennis():
    c1 = np.load(DATA / "c1.npy")[:, :2].astype(float)
    c2 = np.load(DATA / "c2.npy")[:, :2].astype(float)
    world = TABLE_POINTS @ MIRROR_Y
    P1, P2 = dlt_projection(world, c1), dlt_projection(world[[2, 3, 0, 1, 5, 4]], c2)
    rig = Rig((camera_from_projection("phone1", P1, (1280, 720)), camera_from_projection("phone2", P2, (1280, 720))))
    b1 = np.load(DATA / "ballpath1.npy")[:, :2]
    b2 = np.load(DATA / "ballpath2.npy")[:, :2]
    return rig, (P1, P2), (c1, c2), b1, b2


def test_real_tabletennis_triangulation(tabletennis):
    rig, (P1, P2), (c1, c2), b1, b2 = tabletennis
    # The fitted cameras: in front of the table, reprojecting the keypoints within 2 px (the source reports 0.5 to 2 px).
    world = TABLE_POINTS @ MIRROR_Y
    for cam, c, w in ((rig[0], c1, world), (rig[1], c2, world[[2, 3, 0, 1, 5, 4]])):
        assert np.all(cam.depth(w) > 2.0)
        assert np.linalg.norm(cam.project(w)[0] - c, axis=1).max() < 2.1
    both = (b1[:, 0] != 0) & (b2[:, 0] != 0)
    assert both.sum() == 1370
    X = triangulate_pairs(rig[0], rig[1], b1[both], b2[both]) @ MIRROR_Y
    heights = X[:, 2]
    assert np.mean((heights > 0) & (heights < 1.5)) > 0.97  # measured 0.990
    assert 0.15 < np.median(heights) < 0.5  # a ball flying over a table, not a ghost far away
    # Same points as the source's own way (cv2.triangulatePoints on the raw DLT matrices, pixel coordinates):
    # the two least-squares solutions differ only where the noisy rays are far from meeting.
    Xh = cv2.triangulatePoints(P1, P2, np.ascontiguousarray(b1[both].T), np.ascontiguousarray(b2[both].T))
    ref = (Xh[:3] / Xh[3]).T @ MIRROR_Y
    diff = np.linalg.norm(X - ref, axis=1)
    assert np.median(diff) < 0.06 and np.mean(diff < 0.3) > 0.95


def test_real_tabletennis_tracks(tabletennis):
    """The whole classic pipeline after blob finding (epipolar pairing, triangulation, tracks) on 61 s of real detections."""
    rig, _, _, b1, b2 = tabletennis
    # A 6-point DLT on an almost flat table gives a rough epipolar geometry: the median pair is 26 px off its line.
    config = config_from_dict({"targets": [GREEN], "tracker": {"d_max": 20.0}, "baseline": {"max_epipolar_px": 150.0}})
    tracker = BaselineTracker(rig, config)
    fps = 30.0
    objects_seen = confirmed_frames = 0
    lengths: dict[int, int] = {}
    for i in range(len(b1)):
        pa = b1[i : i + 1] if b1[i, 0] != 0 else np.zeros((0, 2))
        pb = b2[i : i + 1] if b2[i, 0] != 0 else np.zeros((0, 2))
        objects, _ = tracker.detections_to_objects({"green": (pa, pb)})
        objects_seen += len(objects)
        tracks = tracker.tracks.update(objects, i / fps)
        confirmed = [t for t in tracks if t.state == "confirmed"]
        assert len(confirmed) <= 2  # one ball (a second only while a stale track coasts into a new one)
        confirmed_frames += bool(confirmed)
        for t in confirmed:
            lengths[t.track_id] = lengths.get(t.track_id, 0) + 1
    assert objects_seen > 0.9 * 1370  # measured 1312
    assert confirmed_frames > 0.75 * 1370  # measured 1102
    # Rallies are cut at bats and bounces (velocity jumps of ~10 m/s in one frame), not every frame.
    assert np.median(list(lengths.values())) >= 10
    assert len(lengths) < 80  # measured 43 confirmed tracks


# --------------------------------------------------------------------------- end to end on drawn frames


def draw_balls(rig: Rig, positions: np.ndarray, radius: float) -> tuple[np.ndarray, ...]:
    """Grey images with each ball as a green disc at its projected centre, sized by depth."""
    images = []
    for cam in rig.cameras:
        img = np.full((cam.height, cam.width, 3), 90, np.uint8)
        uv, _ = cam.project(positions)
        r_px = cam.K[0, 0] * radius / cam.depth(positions)
        for (u, v), r in zip(uv, r_px):
            cv2.circle(img, (int(round(u * 16)), int(round(v * 16))), int(round(r * 16)), (40, 200, 40), -1, cv2.LINE_AA, shift=4)
        images.append(img)
    return tuple(images)


def test_baseline_tracker_end_to_end_on_drawn_frames():
    rig = stereo_rig()
    tracker = BaselineTracker(rig, config_from_dict({"targets": [GREEN]}))
    fps = 30.0
    start = np.array([[-0.3, -0.15, 1.3], [0.1, 0.0, 1.6], [0.3, 0.15, 1.9]])
    velocity = np.array([[0.6, 0.0, 0.0], [0.0, 0.0, 0.5], [-0.5, 0.05, 0.0]])
    ids_per_ball: list[set] = [set(), set(), set()]
    errors = []
    for i in range(12):
        t = i / fps
        truth = start + velocity * t
        frame = FramePair(index=i, images=draw_balls(rig, truth, 0.035), timestamps=(t, t + 0.0005))
        result = tracker.step(frame)
        assert len(result.objects) == 3
        assert set(result.timings_ms) == {"masks", "blobs", "matching", "tracks", "step"}
        assert result.masks[("green", "cam0")].max() == 1
        for tr in result.confirmed:
            d = np.linalg.norm(truth - tr.position, axis=1)
            k = int(np.argmin(d))
            ids_per_ball[k].add(tr.track_id)
            errors.append(d[k])
    assert all(len(s) == 1 for s in ids_per_ball) and len(set.union(*ids_per_ball)) == 3
    assert len(errors) == 3 * 9  # confirmed from 0.1 s (frame 3) on
    # Disc centroids are not exact ball centres (anti-aliasing, perspective): within 1 cm, not 1 micrometre.
    assert np.max(errors) < 0.01


def test_user_errors_are_one_line_messages():
    rig = stereo_rig()
    with pytest.raises(StereotrackError, match="no targets"):
        BaselineTracker(rig, config_from_dict({}))
    tracker = BaselineTracker(rig, config_from_dict({"targets": [GREEN]}))
    small = np.zeros((240, 320, 3), np.uint8)
    with pytest.raises(StereotrackError, match="320x240 but the calibration says 640x480"):
        tracker.step(FramePair(index=0, images=(small, small), timestamps=(0.0, 0.0)))
