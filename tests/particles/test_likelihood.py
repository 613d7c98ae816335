import numpy as np

from stereotrack.camera import Camera, intrinsics_from_fov, look_at
from stereotrack.evidence.colour import integral_image
from stereotrack.particles.likelihood import likelihood, window_counts


def brute_force_counts(mask, uv, window):
    h, w = mask.shape
    half = window // 2
    out = []
    for u, v in uv:
        cx, cy = int(np.rint(u)), int(np.rint(v))
        if not (0 <= cx < w and 0 <= cy < h):
            out.append(0)
            continue
        out.append(int(mask[max(0, cy - half) : cy + half + 1, max(0, cx - half) : cx + half + 1].sum()))
    return np.array(out)


def test_window_counts_match_brute_force():
    rng = np.random.default_rng(0)
    mask = (rng.random((48, 64)) < 0.3).astype(np.uint8)
    uv = np.column_stack([rng.uniform(-5, 69, 2000), rng.uniform(-5, 53, 2000)])
    integ = integral_image(mask)
    for window in (1, 3, 5, 9):
        got = window_counts(integ, uv, np.ones(len(uv), bool), window)
        assert np.array_equal(got, brute_force_counts(mask, uv, window))


def test_invalid_and_nan_projections_count_zero():
    mask = np.ones((10, 10), np.uint8)
    integ = integral_image(mask)
    uv = np.array([[5.0, 5.0], [np.nan, np.nan], [5.0, 5.0]])
    got = window_counts(integ, uv, np.array([True, True, False]), 5)
    assert list(got) == [25, 0, 0]


def test_likelihood_is_product_with_floor():
    K = intrinsics_from_fov(64, 48, 60)
    cams = []
    for x in (-0.1, 0.1):
        R, t = look_at((x, 0, 0), (0, 0, 1))
        cams.append(Camera(f"c{x}", (64, 48), K, np.zeros(5), R, t))
    full = integral_image(np.ones((48, 64), np.uint8))
    empty = integral_image(np.zeros((48, 64), np.uint8))
    X = np.array([[0.0, 0.0, 1.0], [0.0, 0.0, -1.0]])
    assert np.allclose(likelihood(cams, [full, full], X, 5), [1.0, (1 / 25) ** 2])
    assert np.allclose(likelihood(cams, [full, empty], X, 5), [1 / 25, (1 / 25) ** 2])


def test_hidden_by_balls_is_the_shadow_behind_a_ball_only():
    from stereotrack.particles.likelihood import hidden_by_balls

    K = intrinsics_from_fov(64, 48, 60)
    R, t = look_at((0, 0, 0), (0, 0, 1))
    cam = Camera("c", (64, 48), K, np.zeros(5), R, t)
    ball = np.array([[0.0, 0.0, 1.0]])
    pts = np.array(
        [
            [0.0, 0.0, 2.0],  # straight behind the ball: hidden
            [0.02, 0.0, 1.5],  # behind, inside the shadow cone: hidden
            [0.0, 0.0, 0.5],  # in front of the ball: seen
            [0.0, 0.0, 1.01],  # inside the ball itself: not hidden by it
            [0.2, 0.0, 2.0],  # behind but off to the side: seen
        ]
    )
    assert list(hidden_by_balls(cam, pts, ball, np.array([0.035]))) == [True, True, False, False, False]
