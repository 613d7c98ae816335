"""benchmarks/real_footage.py: the hand-checked labels of the real ball videos, and the measure that scores any 2D evidence on them."""

from pathlib import Path

import cv2
import numpy as np
import pytest
from benchmark_scripts import ROOT, load

rf = load("real_footage")

SIZES = {"ball2.mp4": (640, 480), "ball4.mp4": (1280, 720)}


def test_labels_cover_every_tenth_frame_of_both_videos():
    labels = rf.load_labels()
    frames = {v: [lab.frame for lab in labels if lab.video == v] for v in SIZES}
    assert frames["ball2.mp4"] == list(range(0, 1001, 10)) and frames["ball4.mp4"] == list(range(0, 491, 10))
    balls = [lab for lab in labels if lab.ball]
    assert len(balls) == 122 and (ROOT / "tests" / "data" / "ball-videos" / "LICENSE").is_file()
    for lab in balls:
        w, h = SIZES[lab.video]
        assert 10 <= lab.radius <= 80 and 0 <= lab.x < w and 0 <= lab.y < h
        cut = lab.x - lab.radius < 0 or lab.y - lab.radius < 0 or lab.x + lab.radius > w - 1 or lab.y + lab.radius > h - 1
        assert cut == lab.partial, lab


def test_a_blob_inside_the_circle_finds_the_ball_and_every_other_blob_is_false():
    ball = rf.Label("v", 0, True, 100.0, 50.0, 10.0)

    def score(label, centres):
        found, false = rf.score_frame(label, np.array(centres, float))
        return found, false.tolist()

    assert score(ball, [[105.0, 55.0]]) == (True, [False])
    assert score(ball, [[105.0, 55.0], [300.0, 40.0], [115.0, 50.0]]) == (True, [False, True, True])
    assert score(ball, np.zeros((0, 2))) == (False, [])
    assert score(rf.Label("v", 0, False), [[1.0, 2.0], [3.0, 4.0]]) == (False, [True, True])


@pytest.fixture(scope="module")
def drawn_video(tmp_path_factory):
    """A short real video file: a green disc crossing a grey wall, with a small green speck that never moves."""
    folder = tmp_path_factory.mktemp("video")
    writer = cv2.VideoWriter(str(folder / "drawn.avi"), cv2.VideoWriter_fourcc(*"MJPG"), 30.0, (320, 240))
    labels = []
    for i in range(30):
        img = np.full((240, 320, 3), 170, np.uint8)
        cv2.circle(img, (300, 20), 4, (60, 200, 60), -1)
        if i < 25:
            x, y = 40 + 8 * i, 120
            cv2.circle(img, (x, y), 15, (60, 200, 60), -1)
            if i % 5 == 0:
                labels.append(rf.Label("drawn.avi", i, True, float(x), float(y), 15.0))
        elif i % 5 == 0:
            labels.append(rf.Label("drawn.avi", i, False))
        writer.write(img)
    writer.release()
    return folder, labels


def test_measure_runs_the_evidence_over_every_frame_and_scores_the_labelled_ones(drawn_video):
    folder, labels = drawn_video
    hsv = rf.hsv_evidence((50, 100, 100), (70, 255, 255))
    (score,) = rf.measure(hsv, labels, folder).values()
    assert (score.frames, score.ball_frames, score.found) == (6, 5, 5)
    assert score.false_blobs == 6 and score.frames_with_false == 6  # the speck, in every labelled frame
    assert 3 <= score.false_radius <= 6
    seen = []

    def counting():
        def evidence(image):
            seen.append(image.shape)
            return np.zeros((0, 2)), np.zeros(0)

        return evidence

    (nothing,) = rf.measure(counting, labels, folder).values()
    assert nothing.found == 0 and nothing.found_share == 0 and len(seen) == 26  # frames 0..25, in order, each once


def test_labels_match_the_real_videos():
    videos = rf.find_videos()
    if videos is None:
        pytest.skip("the real ball videos are not here (set STEREOTRACK_REAL_DATA to the shared real-data folder)")
    for video, (w, h) in SIZES.items():
        cap = cv2.VideoCapture(str(videos / video))
        assert (int(cap.get(cv2.CAP_PROP_FRAME_WIDTH)), int(cap.get(cv2.CAP_PROP_FRAME_HEIGHT))) == (w, h)
        assert cap.get(cv2.CAP_PROP_FRAME_COUNT) > max(lab.frame for lab in rf.load_labels() if lab.video == video)


@pytest.mark.parametrize("size, grid", [((640, 480), (480, 640)), ((1280, 720), (360, 640))])
def test_the_observation_model_is_built_on_the_trackers_grid_and_answers_in_the_videos_pixels(monkeypatch, size, grid):
    """At 1280x720 the tracker builds its evidence on every other pixel (tracker.evidence_scale): so does the benchmark,
    and the ball's seed is still where the ball is in the video."""
    from stereotrack.evidence.gather import CameraEvidence

    shapes = []
    build = CameraEvidence.from_mask.__func__

    def recording(cls, camera, mask, *args, **kwargs):
        shapes.append(mask.shape)
        return build(cls, camera, mask, *args, **kwargs)

    monkeypatch.setattr(CameraEvidence, "from_mask", classmethod(recording))
    evidence = rf.model_evidence((50, 100, 100), (70, 255, 255))()
    w, h = size
    for i in range(12):  # a green ball crossing a grey wall (the background learns the wall first)
        img = np.full((h, w, 3), 170, np.uint8)
        x, y = w // 4 + 12 * i, h // 2
        cv2.circle(img, (x, y), 30, (60, 200, 60), -1)
        centres, radii = evidence(img)
    assert set(shapes) == {grid}
    assert len(centres) >= 1
    near = np.hypot(centres[:, 0] - x, centres[:, 1] - y) < 3
    assert near.any() and 25 <= radii[near].max() <= 35


def test_the_range_coverage_is_the_median_share_of_the_balls_inner_disc_in_range(monkeypatch):
    """What explains a pale ball's misses: how much of it the typed range takes in, per frame, then the median."""
    frames = []
    for share in (0.2, 0.5, 0.9):
        hsv = np.zeros((100, 100, 3), np.uint8)
        hsv[:] = (60, 40, 200)  # the ball's pale colour: out of the range (S under 80)
        inner = np.zeros((100, 100), bool)
        inner[40:60, 40:60] = True
        hsv[40 : 40 + round(20 * share), 40:60] = (60, 120, 200)  # this share of its rows saturated enough
        frames.append((rf.Label("v", 0, True, 50.0, 50.0, 16.0), hsv, inner))
    monkeypatch.setattr(rf, "whole_ball_frames", lambda labels, videos: iter(frames))
    assert rf.range_coverage([], Path("."), (50, 80, 80), (70, 255, 255)) == pytest.approx(0.5)
    assert rf.range_coverage([], Path("."), (50, 30, 80), (70, 255, 255)) == 1.0  # a range from S 30 takes it all in
