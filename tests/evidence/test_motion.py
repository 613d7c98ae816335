"""The background model: scenery of the ball's colour stays background, a moving ball is foreground, and a
ball the tracks hold stays foreground when it comes to rest."""

from __future__ import annotations

import cv2
import numpy as np
from scene_helpers import RADIUS, default_rig

from stereotrack.evidence.motion import BackgroundModel
from stereotrack.results import TrackedBalls

PINK = (170, 50, 230)  # BGR


def frame(cam, ball=None, wall=True, grey=90):
    img = np.full((cam.height, cam.width, 3), grey, np.uint8)
    if wall:
        cv2.rectangle(img, (300, 80), (620, 400), PINK, -1)  # a wall of the ball's colour
    if ball is not None:
        uv, _, z = cam.view(ball[None])
        cv2.circle(img, (int(uv[0, 0]), int(uv[0, 1])), int(cam.apparent_radius(RADIUS, z[0])), (120, 30, 200), -1)  # a darker pink
    return img


def test_a_static_wall_is_background_and_a_ball_moving_in_front_of_it_is_foreground():
    cam = default_rig().cameras[0]
    bg = BackgroundModel(cam, rate=0.05, threshold=30)
    for _ in range(20):
        fg = bg.foreground(frame(cam))
    assert fg.sum() == 0
    ball = np.array([0.3, 1.5, 0.0])  # in front of the wall
    fg = bg.foreground(frame(cam, ball))
    uv, _, z = cam.view(ball[None])
    r = cam.apparent_radius(RADIUS, z[0])
    u, v = int(uv[0, 0]), int(uv[0, 1])
    assert fg[v - int(r / 2) : v + int(r / 2), u - int(r / 2) : u + int(r / 2)].mean() > 0.9
    assert fg.sum() < 2 * np.pi * r * r  # the ball and little else


def test_a_tracked_ball_at_rest_stays_foreground_an_untracked_one_fades():
    cam = default_rig().cameras[0]
    ball = np.array([-0.3, 1.5, 0.0])
    held = TrackedBalls(ball[None], np.array([RADIUS]), np.array([1]), ("pink",), np.array([True]))
    uv = cam.project(ball[None])[0][0].astype(int)
    for balls, stays in ((held, True), (None, False)):
        bg = BackgroundModel(cam, rate=0.05, threshold=30)
        bg.foreground(frame(cam, wall=False))
        for _ in range(120):  # 4 s at rest
            fg = bg.foreground(frame(cam, ball, wall=False), balls)
        assert bool(fg[uv[1], uv[0]]) == stays


def test_where_a_ball_was_in_the_first_frame_leaves_no_ghost_a_track_could_keep():
    """The first frame starts the background with the balls in it. A ball that then moves on leaves its old
    place looking different from the background (a wall of its colour, where the background holds the ball):
    a ghost. A false track that forms there keeps the place out of the update; the ghost must fade first."""
    cam = default_rig().cameras[0]
    first, later = np.array([0.3, 1.5, 0.0]), np.array([0.55, 1.5, 0.1])  # both in front of the wall
    ghost = TrackedBalls(first[None], np.array([RADIUS]), np.array([1]), ("pink",), np.array([True]))
    u, v = cam.project(first[None])[0][0].astype(int)
    bg = BackgroundModel(cam, rate=0.05, threshold=30)
    bg.foreground(frame(cam, first))
    for i in range(1, 40):  # the ball moved on at once; a track holds its first place from the 5th frame on
        fg = bg.foreground(frame(cam, later), ghost if i >= 5 else None)
    assert fg[v - 2 : v + 3, u - 2 : u + 3].sum() == 0
