"""The shapes the stages hand each other (stereotrack/results.py)."""

import numpy as np

from stereotrack.results import TrackedBalls


def _balls():
    return TrackedBalls(
        np.array([[0.0, 1.0, 0.0], [0.1, 1.5, 0.0], [0.2, 2.0, 0.1]]),
        np.array([0.035, 0.035, 0.04]),
        np.array([3, 5, 8]),
        ("pink", "pink", "orange"),
        np.array([True, True, False]),
        np.array([True, False, True]),
    )


def test_a_selection_of_some_balls_copies_them():
    balls = _balls()
    pink = balls.of("pink")
    assert pink.targets == ("pink", "pink") and np.array_equal(pink.track_ids, [3, 5])
    assert np.array_equal(pink.settled, [True, False]) and pink.centres.shape == (2, 3)
    assert np.array_equal(balls.confirmed_only().track_ids, [3, 5]) and np.array_equal(balls.others("pink").track_ids, [8])
    assert len(balls.where(np.zeros(3, bool))) == 0 and balls.where(np.zeros(3, bool)).centres.shape == (0, 3)


def test_a_selection_of_every_ball_is_those_balls():
    """Most selections a frame keep every ball (one colour, every track confirmed and settled): no copy is made."""
    balls = _balls()
    assert balls.where(np.ones(3, bool)) is balls
    pink = balls.of("pink")
    assert pink.of("pink") is pink and pink.confirmed_only() is pink
