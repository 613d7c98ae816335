from types import SimpleNamespace

import cv2
import numpy as np
from scene_helpers import RADIUS, default_rig, lit_ball

from stereotrack.config import Target
from stereotrack.evidence.blobs import find_blobs
from stereotrack.evidence.colour import integral_image, target_mask, to_hsv
from stereotrack.evidence.gather import CameraEvidence
from stereotrack.objects.surface import (
    OUTLINE_MIN_PX,
    OUTLINE_SHARE,
    SURFACE_RATIO,
    VERDICT_SECONDS,
    SurfacePatches,
    ball_shaped,
    flat,
    in_bar,
    on_surface,
    rimmed,
    round_rim,
    rounded,
    surface_ratio,
    whole_ball,
)
from stereotrack.results import Object3D

WALL_Y = 3.0  # metres ahead of the rig
PINK = Target("pink", (158, 80, 80), (178, 255, 255), RADIUS)  # the range a user would type for _draw's pink


def _draw(rig, wall_texture: bool, ball=None, painted=None, radius=RADIUS, wall=(128, 128, 128), wall_y=WALL_Y):
    """Each camera's image of a wall at ``wall_y`` (a random pattern of 3 cm squares, or flat, of colour ``wall``, BGR), with a
    pink ball before it at ``ball`` (lit from above and in front: shaded) or a pink disc painted on it centred at
    ``painted`` (x, z, one flat colour), ray-traced pixel by pixel."""
    rng = np.random.default_rng(3)
    pattern = rng.integers(40, 220, (200, 200)).astype(np.uint8)
    pink = np.array([180, 105, 255], np.uint8)  # BGR
    images = []
    for cam in rig.cameras:
        v, u = np.mgrid[0 : cam.height, 0 : cam.width]
        o, d = cam.rays(np.column_stack([u.ravel() + 0.5, v.ravel() + 0.5]))
        t = (wall_y - o[:, 1]) / d[:, 1]
        hit = o + t[:, None] * d
        cells = np.clip(((hit[:, [0, 2]] + 3.0) / 0.03).astype(int), 0, 199)
        if wall_texture:
            image = np.repeat(pattern[cells[:, 0], cells[:, 1]][:, None], 3, axis=1)
        else:
            image = np.tile(np.asarray(wall, np.uint8), (len(t), 1))
        if painted is not None:
            image[np.hypot(hit[:, 0] - painted[0], hit[:, 2] - painted[1]) < radius] = pink
        if ball is not None:
            on, lit = lit_ball(o, d, ball, radius)
            image[on] = (pink * (0.35 + 0.65 * lit)[:, None]).astype(np.uint8)
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


def _views(rig, images, moving_at=None):
    """Each camera's evidence as the surface test reads it: the blobs of the images' pink, and the moving map's
    summed-area table, empty or with the box of a ball's disc at ``moving_at`` moving."""
    views = []
    for cam, image in zip(rig.cameras, images):
        moving = np.zeros((cam.height, cam.width), np.uint8)
        if moving_at is not None:
            uv, _, z = cam.view(np.asarray(moving_at, float)[None])
            r = int(cam.apparent_radius(RADIUS, z[0]))
            u, v = (int(c) for c in uv[0])
            moving[v - r : v + r, u - r : u + r] = 1
        pink = (image == (180, 105, 255)).all(axis=2).astype(np.uint8)
        views.append(SimpleNamespace(camera=cam, moving_integral=integral_image(moving), blobs=find_blobs(pink)))
    return views


def test_a_still_patch_is_dropped_its_verdict_kept_a_while_and_a_moving_or_travelled_one_never_judged():
    rig = default_rig()
    painted = np.array([0.2, WALL_Y, 0.1])
    patch = [Object3D("pink", painted, np.eye(3) * 1e-4, 1.0, 100)]
    textured, plain = _draw(rig, True, painted=painted[[0, 2]]), _draw(rig, False, painted=painted[[0, 2]])
    nothing_travelled = np.zeros((0, 3))
    patches = SurfacePatches(RADIUS, rig.cameras, shapes=False)  # the surround's verdict alone (a painted disc is flat)
    assert ball_shaped(painted, RADIUS, _views(rig, textured))  # a disc of a ball's size: the surround tells
    assert patches.drop(patch, _views(rig, textured), textured, nothing_travelled, 0.0).tolist() == [True]
    # Remembered for VERDICT_SECONDS: a flat view (which tells nothing) does not undo it; judged again after
    assert patches.drop(patch, _views(rig, plain), plain, nothing_travelled, 0.5 * VERDICT_SECONDS).tolist() == [True]
    assert patches.drop(patch, _views(rig, plain), plain, nothing_travelled, 2.0 * VERDICT_SECONDS).tolist() == [False]
    # Not judged: a ball that has travelled is there (it came to rest on the wall), or the spot moves in a view
    fresh = SurfacePatches(RADIUS, rig.cameras, shapes=False)
    assert fresh.drop(patch, _views(rig, textured), textured, painted[None] + 0.01, 0.0).tolist() == [False]
    assert fresh.drop(patch, _views(rig, textured, moving_at=painted), textured, nothing_travelled, 0.0).tolist() == [False]
    assert fresh.drop(patch, _views(rig, textured), textured, nothing_travelled, 0.0).tolist() == [True]


def test_a_surround_that_matches_at_the_objects_depth_both_ways_is_a_surface_at_a_lower_margin(monkeypatch):
    """Camera 0 -> 1 at least SURFACE_RATIO decides alone; under it, both ways at least SURFACE_RATIO_BOTH (a book's end on
    a shelf, hue_wall tune seed 68: 1.7 both ways); one way alone under SURFACE_RATIO never does (a still ball, 1.44 one way)."""
    import stereotrack.objects.surface as surface

    rig = default_rig()
    a, b = rig.cameras
    for forth, back, verdict in [(2.5, 0.0, True), (1.7, 1.7, True), (1.7, 0.0, False), (1.44, 1.7, False), (1.7, np.nan, False)]:
        monkeypatch.setattr(surface, "surface_ratio", lambda p, r, c, d, *_, f=forth, k=back: f if c is a else k)
        assert on_surface(np.zeros(3), RADIUS, rig.cameras, [None, None]) is verdict, (forth, back)
    assert surface.SURFACE_RATIO_BOTH < SURFACE_RATIO


def _shapes_views(rig, at, shape: str, scale: float = 1.0, moving: bool = False, radius: float = RADIUS):
    """Each camera's evidence of one pink thing drawn at ``at``'s projection: a disc of ``scale`` times a ball's apparent
    radius there, a square or a flat box as wide as that ball, or a bar ``scale`` times as wide reaching seven radii up
    from under the ball's centre (a slat that a shelf cuts short); still, or moving all over."""
    views = []
    for cam in rig.cameras:
        uv, _, z = cam.view(np.asarray(at, float)[None])
        r = float(cam.apparent_radius(radius, z[0]))
        u, v = (int(round(c)) for c in uv[0])
        mask = np.zeros((cam.height, cam.width), np.uint8)
        if shape == "disc":
            cv2.circle(mask, (u, v), int(round(scale * r)), 1, -1)
        elif shape == "bar":
            k, h = int(round(r)), int(round(scale * r))
            mask[v - 6 * k : v + k + 1, u - h : u + h + 1] = 1
        else:  # a square, or a box as wide and 0.6 as high (a bottle on its side: fills 0.76, axes 0.6)
            k, h = int(round(r)), int(round(r * (0.6 if shape == "box" else 1.0)))
            mask[v - h : v + h + 1, u - k : u + k + 1] = 1
        foreground = np.full((cam.height // 2, cam.width // 2), int(moving), np.uint8)
        views.append(CameraEvidence.from_mask(cam, mask, foreground=foreground))
    return views


def test_a_still_thing_that_shows_as_no_ball_in_any_view_is_dropped():
    """A ball at rest shows as one: in some view a whole disc of a ball's size at its depth (``ball_shaped``). A still
    box (static_props tune seed 74: a bottle on a table) or a blob half as large again as a ball at the depth its views
    put it (seeds 62, 68) is no ball; one that moves, or sits where a tracked ball came to rest, is not judged."""
    rig = default_rig()
    at = np.array([0.1, 1.5, 0.05])
    patches = SurfacePatches(RADIUS, rig.cameras)
    plain = _draw(rig, False, ball=at)  # a shaded ball before a grey wall: the surface test tells nothing
    nothing_travelled = np.zeros((0, 3))
    thing = [Object3D("pink", at, np.eye(3) * 1e-4, 1.0, 100)]
    for shape, scale, shaped in [
        ("disc", 1.0, True),
        ("disc", 0.9, True),
        ("disc", 1.5, False),
        ("square", 1.0, False),
        ("box", 1.0, False),
    ]:
        views = _shapes_views(rig, at, shape, scale)
        assert ball_shaped(at, RADIUS, views) is shaped, (shape, scale)
        assert patches.drop(thing, views, plain, nothing_travelled, 0.0).tolist() == [not shaped], (shape, scale)
    square = _shapes_views(rig, at, "square")
    assert patches.drop(thing, _shapes_views(rig, at, "square", moving=True), plain, nothing_travelled, 0.0).tolist() == [False]
    assert patches.drop(thing, square, plain, at[None] + 0.01, 0.0).tolist() == [False]


def test_a_still_thing_at_the_end_of_a_bar_of_its_colour_in_one_view_is_no_ball_though_a_disc_in_the_other():
    """A slat of the ball's colour that a shelf cuts short ends in a ball's disc with most of its ring empty; with a piece
    of the same slats that is a ball's shape in the other view, it was a ball at rest for the whole scene (hue_wall tune
    seed 147). A still thing whose image lies in a bar of its colour in some view (``in_bar``: BAR_LENGTH or more of its
    radii long, at most BAR_FLAT as long and BAR_WIDTH of its radii wide) is dropped; a disc there is a ball, and so is one
    at the end of a bar narrower or wider than it (a ball at rest touching a stripe of its hue, hue_wall tune seeds 14,
    56); a moving bar is not judged."""
    rig = default_rig()
    at = np.array([0.1, 1.5, 0.05])
    thing = [Object3D("pink", at, np.eye(3) * 1e-4, 1.0, 100)]
    patches, plain = SurfacePatches(RADIUS, rig.cameras), _draw(rig, False, ball=at)
    disc, bar = _shapes_views(rig, at, "disc"), _shapes_views(rig, at, "bar")
    wide, narrow = _shapes_views(rig, at, "bar", scale=2.0), _shapes_views(rig, at, "bar", scale=0.4)
    for n, m in enumerate(narrow):  # the ball's disc at the narrow bar's end: one blob
        uv, _, z = m.camera.view(at[None])
        mask = m.mask.copy()
        cv2.circle(mask, tuple(int(round(c)) for c in uv[0]), int(round(m.camera.apparent_radius(RADIUS, z[0]))), 1, -1)
        narrow[n] = CameraEvidence.from_mask(m.camera, mask, foreground=np.zeros((mask.shape[0] // 2, mask.shape[1] // 2), np.uint8))
    for views, dropped in [
        (disc, False),
        ([disc[0], bar[1]], True),
        ([bar[0], disc[1]], True),
        ([disc[0], wide[1]], False),
        ([disc[0], narrow[1]], False),
    ]:
        assert ball_shaped(at, RADIUS, views)  # a disc of a ball's size in some view: the shape test alone kept it
        assert in_bar(at, RADIUS, views) is dropped
        assert patches.drop(thing, views, plain, np.zeros((0, 3)), 0.0).tolist() == [dropped]
    moving = [disc[0], _shapes_views(rig, at, "bar", moving=True)[1]]
    assert patches.drop(thing, moving, plain, np.zeros((0, 3)), 0.0).tolist() == [False]


def test_a_still_thing_of_one_flat_colour_in_every_view_is_no_ball():
    """A round sticker of the ball's colour on a plain wall (static_props tune seeds 76, 93: a track for the whole scene)
    shows as a ball-sized disc in both views, and a plain surround tells nothing. A ball is shaded: lit on one side,
    darker towards its limb. A still thing whose disc is one flat colour in every view that shows it large enough is
    dropped (``flat``); a shaded ball there is not, nor a thing too small in every view to tell."""
    rig = default_rig()
    at = np.array([0.1, WALL_Y, 0.05])
    thing = [Object3D("pink", at, np.eye(3) * 1e-4, 1.0, 100)]
    views = _shapes_views(rig, at, "disc", 1.0)
    sticker, ball = _draw(rig, False, painted=at[[0, 2]]), _draw(rig, False, ball=at)
    for colour in (None, PINK):
        assert flat(at, RADIUS, rig.cameras, sticker, colour) and not flat(at, RADIUS, rig.cameras, ball, colour)
        patches = SurfacePatches(RADIUS, rig.cameras, colour=colour)
        assert patches.drop(thing, views, sticker, np.zeros((0, 3)), 0.0).tolist() == [True]
        assert patches.drop(thing, views, ball, np.zeros((0, 3)), 1.0).tolist() == [False]
        tiny = RADIUS * 0.15  # under FLAT_MIN_PX pixels of core at 3 m in both views
        assert not flat(at, tiny, rig.cameras, _draw(rig, False, painted=at[[0, 2]], radius=tiny), colour)
        half = [sticker[0], ball[1]]  # flat in one view only: a ball (shaded where it shows)
        assert not flat(at, RADIUS, rig.cameras, half, colour)
    grey = [cv2.cvtColor(i, cv2.COLOR_BGR2GRAY) for i in sticker + ball]  # greyscale cameras: the grey level is the value
    assert flat(at, RADIUS, rig.cameras, grey[:2], PINK) and not flat(at, RADIUS, rig.cameras, grey[2:], PINK)


def test_a_flat_sticker_is_told_by_its_own_pixels_not_by_the_wall_its_core_takes_in():
    """A sticker that is no disc (static_props tune seed 300: an orange arrow on a purple wall) has the wall inside the
    core of the disc its centroid gives it, and its rim blends into the wall: over all the core's pixels its value spans
    the wall's and its own. Only the pixels in the target's range away from their rim count: those are one flat colour
    on a sticker and shaded on a ball, wherever the core falls on either."""
    rig = default_rig()
    at = np.array([0.1, WALL_Y, 0.05])
    off = at + [0.5 * RADIUS, 0.0, 0.0]  # a centroid half a radius off the painted disc's centre: the core takes in wall
    soft = [cv2.GaussianBlur(i, (5, 5), 1.0) for i in _draw(rig, False, painted=at[[0, 2]])]  # a rim blended with the wall
    ball = _draw(rig, False, ball=at)
    assert flat(off, RADIUS, rig.cameras, soft, PINK)
    assert not flat(off, RADIUS, rig.cameras, ball, PINK)
    assert not flat(off, RADIUS, rig.cameras, soft)  # every pixel of the core counted: the wall and the rim look like shading


def test_a_ball_at_rest_before_a_wall_of_its_hue_is_told_by_its_outline_where_no_blob_is_its_disc():
    """A ball at rest before a wall of its hue merges with it in the mask: the one blob is the wall, no ball's disc, and
    the blob test alone dropped the ball for the whole scene (hue_wall tune seeds 163, 145). Its shading steps from the
    wall's colour all round its outline (``rimmed``), where a patch of the plain wall steps nowhere. A thing of the ball's
    colour alone on a grey wall steps all round too, but its own blob judged it, and the outline does not overrule that."""
    rig = default_rig()
    at = np.array([0.1, 1.5, 0.05])
    thing = [Object3D("pink", at, np.eye(3) * 1e-4, 1.0, 100)]
    patches, nothing_travelled = SurfacePatches(RADIUS, rig.cameras, colour=PINK), np.zeros((0, 3))
    pale_pink = (190, 140, 240)  # BGR: hue 165, saturation 106, in PINK's range
    for ball, kept in [(at, True), (None, False)]:
        images = _draw(rig, False, ball=ball, wall=pale_pink)
        views = []
        for cam, image in zip(rig.cameras, images):
            mask = target_mask(to_hsv(image), PINK)
            assert mask.mean() > 0.9  # the ball and the wall: one blob
            views.append(CameraEvidence.from_mask(cam, mask, foreground=np.zeros((cam.height // 2, cam.width // 2), np.uint8)))
        assert not ball_shaped(at, RADIUS, views)
        assert rimmed(at, RADIUS, rig.cameras, images, PINK) is kept
        assert patches.drop(thing, views, images, nothing_travelled, 0.0).tolist() == [not kept]
    # A shaded ball before a grey wall shows its outline, but not before things of its colour: a box's blob stays no ball
    grey_wall = _draw(rig, False, ball=at)
    assert not rimmed(at, RADIUS, rig.cameras, grey_wall, PINK)
    assert patches.drop(thing, _shapes_views(rig, at, "box"), grey_wall, nothing_travelled, 0.0).tolist() == [True]


def test_a_whole_ball_at_rest_against_a_patterned_wall_is_a_ball_though_its_surround_is_at_its_depth(monkeypatch):
    """A ball resting against a wall has the wall's pattern round it at its own depth, and by stereo alone it is a patch
    of the wall (static_props seed 469: a ball at rest before a wall lost for the whole scene). Seen large enough for its
    shape to tell, a disc of its size with its outline all round in every view (``whole_ball``), it is a ball wherever it
    rests. Seen smaller, its surround still decides, as for a far thing whose few pixels a disc's shape fits by chance."""
    import stereotrack.objects.surface as surface

    rig = default_rig()
    wall_y, nothing_travelled = 2.0, np.zeros((0, 3))
    for radius, kept in [(RADIUS, True), (0.5 * RADIUS, False)]:
        at = np.array([0.1, wall_y - radius, 0.05])  # touching the wall
        images = _draw(rig, True, ball=at, radius=radius, wall_y=wall_y)
        views = _shapes_views(rig, at, "disc", radius=radius)
        assert on_surface(at, radius, rig.cameras, images)  # its surround: the wall, at its own depth
        assert ball_shaped(at, radius, views) and not flat(at, radius, rig.cameras, images, PINK)
        assert whole_ball(at, radius, rig.cameras, views, images) is kept, radius
        patches = SurfacePatches(radius, rig.cameras, colour=PINK)
        thing = [Object3D("pink", at, np.eye(3) * 1e-4, 1.0, 100)]
        assert patches.drop(thing, views, images, nothing_travelled, 0.0).tolist() == [not kept], radius
    # Without the whole-ball test, the surround drops the large one too
    at = np.array([0.1, wall_y - RADIUS, 0.05])
    images = _draw(rig, True, ball=at, wall_y=wall_y)
    monkeypatch.setattr(surface, "WHOLE_MIN_PX", 1e9)
    thing = [Object3D("pink", at, np.eye(3) * 1e-4, 1.0, 100)]
    dropped = SurfacePatches(RADIUS, rig.cameras, colour=PINK).drop(thing, _shapes_views(rig, at, "disc"), images, nothing_travelled, 0.0)
    assert dropped.tolist() == [True]


def _shaded_squares(rig, at, images, radius: float = RADIUS):
    """``images`` with a pink square as wide as a ball at ``at`` drawn over its projection in each, lit from above (its
    value falls by half from top to bottom: shaded, as a cube's face is)."""
    out = []
    for cam, image in zip(rig.cameras, images):
        uv, _, z = cam.view(np.asarray(at, float)[None])
        r = float(cam.apparent_radius(radius, z[0]))
        u, v, k = int(round(uv[0][0])), int(round(uv[0][1])), int(round(r))
        image = image.copy()
        light = np.linspace(1.0, 0.5, 2 * k + 1)[:, None, None]
        image[v - k : v + k + 1, u - k : u + k + 1] = (np.array([180, 105, 255]) * light).astype(np.uint8)
        out.append(image)
    return out


def test_a_still_thing_whose_outline_is_round_in_no_view_is_no_ball():
    """A cube of the ball's colour on a stand, seen by both cameras at one depth (static_props seed 151: a track for 85
    frames), is a blob of a ball's size and shaded, and its surround lies behind it: every test but its outline's keeps
    it. A ball's outline crosses a circle of its size radially all round (``round_rim``), a square's only where its sides
    meet the circle. A still thing whose outline is round in no view that shows it OUTLINE_MIN_PX or more in radius is
    dropped (``rounded``); a ball is not, nor a thing round in one view only (a ball that the other view hides, or whose
    depth is not yet found), nor a square too small in every view to tell."""
    rig = default_rig()
    at = np.array([0.1, 1.5, 0.05])
    thing = [Object3D("pink", at, np.eye(3) * 1e-4, 1.0, 100)]
    patches, views, nothing_travelled = SurfacePatches(RADIUS, rig.cameras, colour=PINK), _shapes_views(rig, at, "disc"), np.zeros((0, 3))
    ball = _draw(rig, False, ball=at)
    square = _shaded_squares(rig, at, _draw(rig, False))
    for cam, b, s in zip(rig.cameras, ball, square):
        uv, _, z = cam.view(at[None])
        uv, r = uv[0], float(cam.apparent_radius(RADIUS, z[0]))
        assert r >= OUTLINE_MIN_PX and round_rim(b, uv, r) >= 0.8 and round_rim(s, uv, r) < OUTLINE_SHARE
    assert not flat(at, RADIUS, rig.cameras, square, PINK)  # shaded: the flat test keeps it
    for images, dropped in [(ball, False), (square, True), ([ball[0], square[1]], False), ([square[0], ball[1]], False)]:
        assert rounded(at, RADIUS, rig.cameras, images) is not dropped
        assert patches.drop(thing, views, images, nothing_travelled, 0.0).tolist() == [dropped]
    far = np.array([0.1, 9.0, 0.05])  # a few pixels across in each view: its outline tells nothing
    assert all(cam.apparent_radius(RADIUS, cam.view(far[None])[2][0]) < OUTLINE_MIN_PX for cam in rig.cameras)
    assert rounded(far, RADIUS, rig.cameras, _shaded_squares(rig, far, _draw(rig, False)))


def test_a_calm_white_thing_that_the_moving_map_holds_must_show_a_round_outline():
    """A white or grey ball's shading keeps it in the moving map at rest, so ``still`` never holds for it; what the
    judge is told instead is whether anything changed lately in its disc (``calm``: motion.BackgroundModel.changed). A
    calm thing away from every ball that has travelled must show a round outline in some view, with each view's circle
    re-centred within a couple of pixels (its object is its shading's cluster): a white table's corner, shaded like a
    ball (white_ball tune seed 89: a false track for 70 frames), is dropped; a ball at rest is not, nor one whose object
    sits a pixel or two off it, nor a thing that moves, nor one where a travelled ball came to rest."""
    rig = default_rig()
    at = np.array([0.1, 1.5, 0.05])
    thing = [Object3D("white", at, np.eye(3) * 1e-4, 1.0, 100)]
    patches, nothing_travelled = SurfacePatches(RADIUS, rig.cameras, shapes=False), np.zeros((0, 3))
    views = _views(rig, _draw(rig, False), moving_at=at)  # in the moving map: never ``still``
    ball, square = _draw(rig, False, ball=at), _shaded_squares(rig, at, _draw(rig, False))
    for images, calm, dropped in [(square, True, True), (ball, True, False), (square, False, False), (square, None, False)]:
        calm = None if calm is None else np.array([calm])
        assert patches.drop(thing, views, images, nothing_travelled, 0.0, calm).tolist() == [dropped]
    assert patches.drop(thing, views, square, at[None] + 0.01, 0.0, np.array([True])).tolist() == [False]
    # its object two and a half pixels off the ball in each view: round only once re-centred
    off = at + np.array([0.005, 0.0, -0.005])
    shifts = [np.linalg.norm(cam.view(off[None])[0][0] - cam.view(at[None])[0][0]) for cam in rig.cameras]
    assert all(2.0 <= s <= 3.0 for s in shifts), shifts
    assert not rounded(off, RADIUS, rig.cameras, ball) and rounded(off, RADIUS, rig.cameras, ball, recentre=True)
    off_thing = [Object3D("white", off, np.eye(3) * 1e-4, 1.0, 100)]
    assert patches.drop(off_thing, views, ball, nothing_travelled, 0.0, np.array([True])).tolist() == [False]
