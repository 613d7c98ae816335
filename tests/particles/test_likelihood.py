import numpy as np

from stereotrack.camera import Camera, intrinsics_from_fov, look_at
from stereotrack.evidence.colour import integral_image
from stereotrack.particles.likelihoods.colour_window import likelihood, window_counts


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
    from stereotrack.particles.likelihoods.colour_window import hidden_by_balls

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


def test_models_are_the_files_of_the_likelihoods_folder_and_a_wrong_name_is_one_clear_error():
    import pytest

    from stereotrack.config import Target, TrackerSettings
    from stereotrack.errors import StereotrackError
    from stereotrack.particles.likelihoods import available, make_likelihood
    from stereotrack.particles.likelihoods.colour_window import ColourWindow

    pink = Target("pink", (140, 60, 50), (175, 255, 255))
    assert "colour_window" in available()
    model = make_likelihood(TrackerSettings(window=7, likelihood="colour_window"), pink)
    assert isinstance(model, ColourWindow) and model.window == 7
    with pytest.raises(StereotrackError, match="unknown model 'colour_windw'.*colour_window"):
        make_likelihood(TrackerSettings(likelihood="colour_windw"), pink)


def test_the_colour_window_model_is_eq_14_over_the_evidence():
    """The model behind the interface gives what the eq. 14 function gives on the same masks."""
    from scene_helpers import RADIUS, default_rig, disc_masks, evidence

    from stereotrack.particles.likelihoods.colour_window import ColourWindow

    rig = default_rig()
    balls = np.array([[0.0, 1.5, 0.0], [0.2, 1.9, 0.1]])
    masks, integrals = disc_masks(rig, balls)
    rng = np.random.default_rng(3)
    X = np.vstack([balls, balls[0] + rng.normal(0, 2 * RADIUS, (200, 3))])
    got = ColourWindow(5)(X, evidence(rig, masks), None)
    assert np.array_equal(got, likelihood(rig.cameras, integrals, X, 5))
    assert got[0] == 1.0 and got.min() < 0.01
