import numpy as np
from scene_helpers import RADIUS, default_rig

from stereotrack.objects.surface import SURFACE_RATIO, on_surface, surface_ratio

WALL_Y = 3.0  # metres ahead of the rig


def _draw(rig, wall_texture: bool, ball=None, painted=None, radius=RADIUS):
    """Each camera's image of a wall at WALL_Y (a random pattern of 3 cm squares, or flat grey), with a pink ball before it
    at ``ball`` or a pink disc painted on it centred at ``painted`` (x, z), ray-traced pixel by pixel."""
    rng = np.random.default_rng(3)
    pattern = rng.integers(40, 220, (200, 200)).astype(np.uint8)
    pink = np.array([180, 105, 255], np.uint8)  # BGR
    images = []
    for cam in rig.cameras:
        v, u = np.mgrid[0 : cam.height, 0 : cam.width]
        o, d = cam.rays(np.column_stack([u.ravel() + 0.5, v.ravel() + 0.5]))
        t = (WALL_Y - o[:, 1]) / d[:, 1]
        hit = o + t[:, None] * d
        cells = np.clip(((hit[:, [0, 2]] + 3.0) / 0.03).astype(int), 0, 199)
        grey = pattern[cells[:, 0], cells[:, 1]] if wall_texture else np.full(len(t), 128, np.uint8)
        image = np.repeat(grey[:, None], 3, axis=1)
        if painted is not None:
            image[np.hypot(hit[:, 0] - painted[0], hit[:, 2] - painted[1]) < radius] = pink
        if ball is not None:
            oc = o - np.asarray(ball, float)
            b = np.einsum("ij,ij->i", oc, d)
            image[b * b - (np.einsum("ij,ij->i", oc, oc) - radius**2) > 0] = pink
        images.append(np.ascontiguousarray(image.reshape(cam.height, cam.width, 3)))
    return images


def test_a_disc_painted_on_a_patterned_wall_is_on_the_surface_and_a_ball_before_it_is_not():
    rig = default_rig()
    painted = np.array([0.2, WALL_Y, 0.1])
    images = _draw(rig, True, painted=painted[[0, 2]])
    assert surface_ratio(painted, RADIUS, *rig.cameras, *images) >= SURFACE_RATIO
    assert on_surface(painted, RADIUS, rig.cameras, images)
    ball = np.array([0.2, 1.5, 0.1])
    images = _draw(rig, True, ball=ball)
    assert surface_ratio(ball, RADIUS, *rig.cameras, *images) < 1.0  # the wall behind it matches better
    assert not on_surface(ball, RADIUS, rig.cameras, images)


def test_a_flat_wall_tells_nothing():
    """Around a disc on a wall of one grey, every depth matches alike: no verdict, the object stays."""
    rig = default_rig()
    painted = np.array([0.2, WALL_Y, 0.1])
    images = _draw(rig, False, painted=painted[[0, 2]])
    assert not on_surface(painted, RADIUS, rig.cameras, images)


def test_an_object_out_of_a_view_is_not_judged():
    rig = default_rig()
    images = _draw(rig, True)
    assert np.isnan(surface_ratio(np.array([5.0, 1.0, 0.0]), RADIUS, *rig.cameras, *images))
    assert not on_surface(np.array([5.0, 1.0, 0.0]), RADIUS, rig.cameras, images)
