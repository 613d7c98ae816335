import numpy as np
from scene_helpers import RADIUS, balls_at, default_rig, disc_masks, evidence

from stereotrack.evidence.blobs import find_blobs
from stereotrack.objects.explain import ExplainSettings, explain
from stereotrack.results import Object3D


def obj(position, along=None, sigma=0.005, mass=0.25):
    """An object as the clusters give it: tight across, ``sigma`` along ``along`` (default: round)."""
    cov = np.eye(3) * 0.005**2
    if along is not None:
        cov = cov + (sigma**2 - 0.005**2) * np.outer(along, along)
    return Object3D("pink", np.asarray(position, float), cov, mass, 100)


def test_stereo_ghosts_are_dropped_and_balls_kept():
    rig = default_rig()
    a, b = np.array([-0.1, 1.2, 0.0]), np.array([0.1, 1.6, 0.0])
    masks, _ = disc_masks(rig, np.array([a, b]))
    c0, c1 = rig.cameras
    ua, ub = c0.project(np.array([a, b]))[0], c1.project(np.array([a, b]))[0]
    ghosts = [rig.triangulate([ua[0], ub[1]]), rig.triangulate([ua[1], ub[0]])]
    objects = [obj(g) for g in ghosts] + [obj(a), obj(b)]
    kept, into = explain(objects, evidence(rig, masks), ExplainSettings(radius=RADIUS))
    assert len(kept) == 2
    assert list(into[:2]) == [-1, -1]
    found = np.array([o.position for o in kept])
    for ball in (a, b):
        assert np.linalg.norm(found - ball, axis=1).min() < 0.005


def test_a_ball_in_a_shared_blob_takes_the_depth_where_the_discs_make_up_the_blob():
    """Ball B is partly hidden behind A in cam1 (one blob there) and clean in cam0. B's particles are
    pulled 8 cm along cam0's ray towards A; fitting A's and B's discs to cam1's blob puts B back."""
    rig = default_rig()
    c0, c1 = rig.cameras
    a = np.array([0.0, 1.0, 0.0])
    ray1 = (a - c1.centre) / np.linalg.norm(a - c1.centre)
    b = c1.centre + 1.5 * ray1 + np.array([0.0, 0.0, 0.03])
    masks, _ = disc_masks(rig, np.array([a, b]))
    blobs = [find_blobs(m) for m in masks]
    assert [len(x) for x in blobs] == [2, 1]
    ray0 = (b - c0.centre) / np.linalg.norm(b - c0.centre)
    biased = b - 0.08 * ray0
    objects = [obj(a, ray1, 0.03), obj(biased, ray0, 0.1)]
    for fit, worst in ((True, 0.025), (False, None)):
        kept, _ = explain(objects, evidence(rig, masks), ExplainSettings(radius=RADIUS, disc_fit=fit))
        assert len(kept) == 2
        error = np.linalg.norm(kept[1].position - b)
        if worst is not None:
            assert error < worst
            assert np.sqrt(ray0 @ kept[1].covariance @ ray0) < 0.04  # and says it knows the depth
        else:
            assert error > 0.06  # without the fit the particles' bias stays
        assert np.linalg.norm(kept[0].position - a) < 0.02


def test_a_ball_cut_by_a_nearer_ball_of_another_colour_is_not_placed_by_its_cut_blob():
    """An orange ball in front of a pink one covers part of the pink disc in cam0 only. The cut blob
    still looks ball-sized (it keeps its other extent) but its centroid is off the ball's centre:
    told where the orange ball is, explain takes the pink ball's depth along its clean cam1 view."""
    rig = default_rig()
    c0, c1 = rig.cameras
    pink = np.array([0.0, 1.8, 0.0])
    ray0 = (pink - c0.centre) / np.linalg.norm(pink - c0.centre)
    orange = c0.centre + 1.2 * ray0 + np.array([-0.042, 0.0, 0.0])  # overlaps about a third of the pink disc in cam0
    pink_masks, _ = disc_masks(rig, pink[None])
    orange_masks, _ = disc_masks(rig, orange[None])
    masks = [p & (1 - o) for p, o in zip(pink_masks, orange_masks)]
    cut = [int(p.sum() - m.sum()) for p, m in zip(pink_masks, masks)]
    assert cut[0] > 60 and cut[1] == 0  # cut in cam0 only
    objects = [obj(pink + 0.004 * ray0)]  # the particles are right, to within their noise
    occluders = balls_at(orange[None], target="orange")
    naive, _ = explain(objects, evidence(rig, masks), ExplainSettings(radius=RADIUS))
    told, _ = explain(objects, evidence(rig, masks), ExplainSettings(radius=RADIUS), occluders=occluders)
    assert np.linalg.norm(naive[0].position - pink) > 0.04  # triangulating the cut centroid is far off in depth
    assert np.linalg.norm(told[0].position - pink) < 0.01


def test_a_thin_streak_places_its_ball_at_its_triangulated_centroid():
    """A fast ball's streak whose colour the background diluted at its edges: 0.6 of the ball's width in range, longer
    than the ball. Its centroid is the ball's mean position: an object the particles put 8 cm off along the depth takes
    the triangulated centroids (its size alone would call the view unclean: a ball that narrow is farther), when it moves."""

    ball = np.array([0.0, 1.5, 0.0])
    rig, masks, moving = _blurred(ball, np.array([0.1, 0.0, 0.0]), width=1.2)  # every pixel of it moves
    off = ball + 0.08 * ball / np.linalg.norm(ball)
    kept, _ = explain([obj(off)], moving, ExplainSettings(radius=RADIUS))
    assert len(kept) == 1 and np.linalg.norm(kept[0].position - ball) < 0.02, kept[0].position
    # A static prop of that shape is no streak: its object keeps the particles' word.
    kept, _ = explain([obj(off)], evidence(rig, masks), ExplainSettings(radius=RADIUS))
    assert np.linalg.norm(kept[0].position - off) < 0.01


def _blurred(ball: np.ndarray, velocity: np.ndarray, width: float = 2.0, edge_px: float = 0.0):
    """The default rig, and per camera the mask of a ball swept from ``ball - velocity`` to ``ball + velocity`` during
    the exposure (a line ``width`` ball radii wide: 2 for the whole ball, less where the background diluted its edges,
    plus ``edge_px`` pixels: the pixels its edges cross in part), with its evidence, the mask moving all over."""
    import cv2

    from stereotrack.evidence.gather import CameraEvidence

    rig = default_rig()
    masks = []
    for cam in rig.cameras:
        m = np.zeros((cam.height, cam.width), np.uint8)
        (a, b), r = cam.project(np.array([ball - velocity, ball + velocity]))[0], cam.K[0, 0] * RADIUS / cam.depth(ball[None])[0]
        cv2.line(
            m, tuple(int(round(x * 16)) for x in a), tuple(int(round(x * 16)) for x in b), 1, int(round(width * r + edge_px)), cv2.LINE_8, 4
        )
        masks.append(m)
    return rig, masks, tuple(CameraEvidence.from_mask(c, m, foreground=m) for c, m in zip(rig.cameras, masks))


def test_a_far_streak_takes_its_triangulated_centroid_where_the_particles_stray_more_than_three_radii():
    """At 6 m a streak is long against its disparity along the epipolar lines, and the particles' mean strays 0.3 m
    in depth (8.6 radii); the centroids triangulate to their half pixel, so the blobs agree within 3 radii plus 3
    standard deviations of the triangulation (about 0.15 m along the depth there)."""
    ball = np.array([0.1, 6.0, 0.0])
    rig, masks, views = _blurred(ball, np.array([0.15, 0.0, 0.02]))
    assert all(v.blobs.swept[0] for v in views)
    off = ball - 0.3 * ball / np.linalg.norm(ball)
    kept, _ = explain([obj(off)], views, ExplainSettings(radius=RADIUS))
    assert len(kept) == 1 and np.linalg.norm(kept[0].position - ball) < 0.1, kept[0].position


def test_a_streak_that_moves_only_in_part_in_one_view_is_a_streak_where_its_other_view_is_one():
    """A fast ball's faint streak that the background's coarse grid sees moving only in part in one camera (a third of
    it) is still its ball's streak when the other camera's blob of that ball is a moving streak: a ball is smeared in
    every view or in none. Its centroids triangulate where the particles put the ball 0.3 m far (fast_ball tune seed
    436: 0.3 m far for 10 frames). Moving in part in both views, it is no streak: its object keeps the particles' word."""
    from stereotrack.evidence.gather import CameraEvidence

    ball = np.array([0.1, 6.0, 0.0])
    rig, masks, views = _blurred(ball, np.array([0.15, 0.0, 0.02]))
    xs = [np.flatnonzero(m.any(axis=0)) for m in masks]
    part = [m.copy() for m in masks]
    for m, x in zip(part, xs):
        m[:, x[0] + len(x) // 3 :] = 0  # the streak's first third moves
    off = ball + 0.3 * ball / np.linalg.norm(ball)
    objects = [obj(off, ball / np.linalg.norm(ball), 0.3)]
    one_in_part = (views[0], CameraEvidence.from_mask(rig.cameras[1], masks[1], foreground=part[1]))
    kept, _ = explain(objects, one_in_part, ExplainSettings(radius=RADIUS))
    assert len(kept) == 1 and kept[0].swept and np.linalg.norm(kept[0].position - ball) < 0.1, kept[0].position
    both_in_part = tuple(CameraEvidence.from_mask(c, m, foreground=f) for c, m, f in zip(rig.cameras, masks, part))
    kept, _ = explain(objects, both_in_part, ExplainSettings(radius=RADIUS))
    assert len(kept) == 1 and not kept[0].swept and np.linalg.norm(kept[0].position - off) < 0.05, kept[0].position


def test_a_streak_cut_short_in_one_view_leaves_its_depth_to_the_particles():
    """A fast ball's streak of which one camera's mask holds only the first half (the rest faded out of range) has its
    centroid a quarter of the streak's length off along it, which along the epipolar lines is depth: triangulated, the
    ball lands metres off along the ray (fast_ball tune seed 428: a streak half as long as the other view's put the
    ball 0.37 m near, claiming 0.04 m; the track took it and flew off). Under CUT_SHORT of the other view's length, that
    view is no clean view, and the particles keep their word on the depth. Cut by a tenth, it still triangulates."""
    from stereotrack.evidence.gather import CameraEvidence

    ball = np.array([0.1, 6.0, 0.0])
    ray = ball / np.linalg.norm(ball)
    for share, triangulated in ((0.5, False), (0.9, True)):
        rig, masks, views = _blurred(ball, np.array([0.25, 0.0, 0.0]))
        cut = masks[0].copy()
        x = np.flatnonzero(cut.any(axis=0))
        cut[:, x[0] + int(share * len(x)) :] = 0
        views = (CameraEvidence.from_mask(rig.cameras[0], cut, foreground=cut), views[1])
        kept, _ = explain([obj(ball, ray, 0.3)], views, ExplainSettings(radius=RADIUS))
        assert len(kept) == 1 and kept[0].swept == triangulated, share
        if not triangulated:
            assert np.linalg.norm(kept[0].position - ball) < 0.01, kept[0].position


def test_a_far_thin_streak_whose_edge_pixels_count_takes_its_triangulated_centroid():
    """A far ball's streak (2.4 pixels of radius at 8 m) marks every pixel its edges cross: a band 2 r + 1 pixels wide,
    whose moments' semi-minor axis is 2 sqrt(r (r + 1) / 3) = 3.3 pixels (here 3.8), 1.5 times the ball's radius. It is
    still the ball's streak, and its centroids triangulate to a few centimetres where the particles put the ball 0.3 m
    near (fast_ball tune seed 33: streaks 2.1-2.2 pixels half wide of a ball of 1.45, placed by its particles)."""
    ball = np.array([0.1, 8.0, 0.0])
    rig, masks, views = _blurred(ball, np.array([0.15, 0.0, 0.02]), edge_px=1.0)
    assert all(
        v.blobs.swept[0] and v.blobs.axes[0, 1] > 1.4 * v.camera.apparent_radius(RADIUS, v.camera.depth(ball[None]))[0] for v in views
    )
    off = ball - 0.3 * ball / np.linalg.norm(ball)
    kept, _ = explain([obj(off, ball / np.linalg.norm(ball), 0.3)], views, ExplainSettings(radius=RADIUS))
    assert len(kept) == 1 and kept[0].swept and np.linalg.norm(kept[0].position - ball) < 0.05, kept[0].position


def test_a_short_blur_of_a_moving_ball_takes_its_triangulated_centroid():
    """A big ball blurred to 1.6 times its width is no streak to the blob finder (it asks for 2), so the particles
    judge it by its larger side and put it 12 % too near, claiming a spread a fifth of that. Moving, as full and as
    even as a streak, its width is the ball's and its centroid the ball's mean position: the object takes the
    triangulated centroids. The same shape at rest (a half-lit ball, a prop) keeps the particles' word."""
    ball = np.array([0.05, 1.5, 0.0])
    rig, masks, views = _blurred(ball, np.array([0.018, 0.0, 0.0]))
    for v in views:
        (a, b), swept = v.blobs.axes[0], v.blobs.swept[0]
        assert 1.4 < a / b < 1.9 and not swept, (a, b, swept)  # a short blur: no streak to the blob finder
    ray = ball / np.linalg.norm(ball)
    off = ball - 0.12 * np.linalg.norm(ball) * ray
    kept, _ = explain([obj(off, ray, 0.035)], views, ExplainSettings(radius=RADIUS))
    assert len(kept) == 1 and np.linalg.norm(kept[0].position - ball) < 0.01, kept[0].position
    assert kept[0].swept  # placed at streaks: the track manager may confirm it at once
    kept, _ = explain([obj(off, ray, 0.035)], evidence(rig, masks), ExplainSettings(radius=RADIUS))
    assert np.linalg.norm(kept[0].position - off) < 0.01 and not kept[0].swept
    # A target of every hue (white, grey) takes no short blurs: its moving map holds a ball's shaded side and a slow
    # ball's trail, which stretch its blob as a blur would.
    kept, _ = explain([obj(off, ray, 0.035)], views, ExplainSettings(radius=RADIUS, short_streaks=False))
    assert np.linalg.norm(kept[0].position - off) < 0.01 and not kept[0].swept


def test_a_short_blur_wider_than_its_ball_is_no_clean_view():
    """A short blur's cross-section is a disc's, not a band's: one 1.4 times as wide as its ball is a ball merged with
    something beside it (hands tune seed 38), and its object keeps the particles' word (a long streak may be as wide as
    the band a ball marks, 2 sqrt(r (r + 1) / 3) > 1.15 r, in any size)."""
    ball = np.array([0.05, 1.5, 0.0])
    rig, masks, views = _blurred(ball, np.array([0.025, 0.0, 0.0]), width=2.8)
    for v in views:
        (a, b), swept = v.blobs.axes[0], v.blobs.swept[0]
        assert 1.2 < a / b < 1.9 and not swept and b > 1.35 * v.camera.apparent_radius(RADIUS, v.camera.depth(ball[None]))[0], (a, b)
    ray = ball / np.linalg.norm(ball)
    off = ball - 0.05 * np.linalg.norm(ball) * ray
    kept, _ = explain([obj(off, ray, 0.035)], views, ExplainSettings(radius=RADIUS))
    assert np.linalg.norm(kept[0].position - off) < 0.01 and not kept[0].swept, kept[0].position


def test_a_far_ball_takes_its_triangulated_centroids_where_its_particles_stray_along_the_ray_as_far_as_they_claim():
    """A far ball blurred a little (no streak) shows a core in range smaller than the ball: its particles put it 0.3 m
    too far at 3 m (8.6 radii), and say so (0.15 m along the ray). Its clean blobs triangulate to their half pixel:
    the object takes them, off by more than three radii but along the viewing ray only, within two standard
    deviations of what both claim there. Claiming 3 cm, the particles keep their word (fast_ball tune seed 16:
    0.400 -> 0.945)."""
    rig = default_rig()
    ball = np.array([0.1, 3.0, 0.0])
    masks, _ = disc_masks(rig, ball[None])
    ray = (ball - rig.cameras[0].centre) / np.linalg.norm(ball - rig.cameras[0].centre)
    off = ball + 0.3 * ray
    kept, _ = explain([obj(off, ray, 0.15)], evidence(rig, masks), ExplainSettings(radius=RADIUS))
    assert len(kept) == 1 and np.linalg.norm(kept[0].position - ball) < 0.05, kept[0].position
    kept, _ = explain([obj(off, ray, 0.03)], evidence(rig, masks), ExplainSettings(radius=RADIUS))
    assert np.linalg.norm(kept[0].position - off) < 0.01
    # A white or grey ball (no partial views for it) takes them too where its blobs are whole discs, as a ball at rest
    # shows its shading's (white_ball seed 222: its particles 0.12-0.17 m near, claiming 0.12 m).
    kept, _ = explain([obj(off, ray, 0.15)], evidence(rig, masks), ExplainSettings(radius=RADIUS, partial_views=False))
    assert np.linalg.norm(kept[0].position - ball) < 0.05, kept[0].position
    # A near ball whose particles claim its depth to 2 radii, 3.5 radii off: they keep their word (the triangulation is
    # taken only where the particles claim no better than three radii; lighting tune seed 6 0.967 -> 0.856 else).
    near = np.array([0.1, 1.9, 0.0])
    masks, _ = disc_masks(rig, near[None])
    ray = (near - rig.cameras[0].centre) / np.linalg.norm(near - rig.cameras[0].centre)
    off = near + 3.5 * RADIUS * ray
    kept, _ = explain([obj(off, ray, 2 * RADIUS)], evidence(rig, masks), ExplainSettings(radius=RADIUS))
    assert np.linalg.norm(kept[0].position - off) < 0.01, kept[0].position


def test_a_far_ball_takes_its_triangulated_centroids_where_its_particles_fall_in_its_disc_in_every_view():
    """A far ball's particles judge its depth by its size, and a ball's mask is smaller than its disc (its darker rim is
    out of the range): they drift far along the ray while claiming their depth to a few centimetres (fast_ball tune seed
    1: a handball at 7.3 m, 0.3 m far and on to 0.95 m, claiming 0.1-0.2 m; its centroids triangulated to 2 cm). At
    6 m, 0.3 m along the ray moves the ball's disc by 0.41 of its radius in the other view: the particles and the
    centroids are one disc in every view, and the disparity, which the particles hardly judge there, places it."""
    rig = default_rig()
    ball = np.array([0.1, 6.0, 0.0])
    masks, _ = disc_masks(rig, ball[None])
    ray = (ball - rig.cameras[0].centre) / np.linalg.norm(ball - rig.cameras[0].centre)
    kept, _ = explain([obj(ball + 0.3 * ray, ray, 0.03)], evidence(rig, masks), ExplainSettings(radius=RADIUS))
    assert len(kept) == 1 and np.linalg.norm(kept[0].position - ball) < 0.05, kept[0].position


def test_a_short_thin_blur_that_does_not_fill_its_disc_is_no_ball_seen_in_part():
    """A ball blurred to 1.8 times the width its colour keeps in range (0.6 of the ball's: the background it swept over
    dilutes its edges) is no longer than the ball and fills 0.6 of the disc its length spans, as a ball cut in half by a
    prop does; it is as full and as elongated as a half disc too. But it is as wide on either side of its path, where a
    half disc has a flat side and a curved one: its views are clean, and the object takes their triangulated centroids
    (fast_ball tune seed 1: the partial-view fit on such blurs, or no fit, lost the ball's depth)."""
    ball = np.array([0.05, 1.5, 0.0])
    rig, masks, views = _blurred(ball, np.array([0.017, 0.0, 0.006]), width=1.2)
    for v, cam in zip(views, rig.cameras):
        (a, b), size, fill = v.blobs.axes[0], v.blobs.radii[0], v.blobs.areas[0] / (np.pi * v.blobs.radii[0] ** 2)
        assert 1.6 < a / b < 2.0 and fill < 0.7 and size < 1.15 * cam.apparent_radius(RADIUS, cam.depth(ball[None]))[0]
    off = ball + 0.08 * ball / np.linalg.norm(ball)
    kept, _ = explain([obj(off)], views, ExplainSettings(radius=RADIUS))
    assert len(kept) == 1 and np.linalg.norm(kept[0].position - ball) < 0.02, kept[0].position


def _cut_in_cam1(rig, ball, columns):
    """Masks of one ball, with cam1's disc cut by a grey bar in front of it: columns (in ball radii from the
    disc's centre, left to right) where nothing of the ball shows."""
    masks, _ = disc_masks(rig, ball[None])
    c1 = rig.cameras[1]
    u = c1.project(ball[None])[0][0, 0]
    r = c1.apparent_radius(RADIUS, c1.depth(ball[None]))[0]
    masks[1][:, int(round(u + columns[0] * r)) : int(round(u + columns[1] * r))] = 0
    return masks


def test_a_ball_seen_in_part_in_one_view_is_placed_by_the_disc_that_holds_what_shows():
    """A grey pole splits a pink ball's disc in cam1 (a sliver left of it, the rest right), or a box hides its
    left part. The right part's blob is as tall as the ball, so it looked ball-sized and clean, and its centroid,
    half a radius off the ball's, triangulated 0.1-0.2 m too deep (static_props tune seed 0). The ball's depth
    along its whole cam0 view is where its disc in cam1 holds every part that shows."""
    rig = default_rig()
    c0 = rig.cameras[0]
    pink = np.array([-0.2, 1.8, -0.1])
    ray0 = (pink - c0.centre) / np.linalg.norm(pink - c0.centre)
    for columns in ((-0.75, 0.05), (-1.5, -0.2)):
        masks = _cut_in_cam1(rig, pink, columns)
        objects = [obj(pink + 0.15 * ray0, ray0, 0.05)]  # the particles, pulled deep by the part that shows
        kept, _ = explain(objects, evidence(rig, masks), ExplainSettings(radius=RADIUS))
        assert len(kept) == 1
        assert np.linalg.norm(kept[0].position - pink) < 0.03, columns
        # A target of every hue (white, grey) fits no partial views: its shaded side is out of its range, so its blob is
        # a crescent wherever it is. Its cut view counts as a whole one, and its centroid pulls the ball deep.
        kept, _ = explain(objects, evidence(rig, masks), ExplainSettings(radius=RADIUS, partial_views=False))
        assert np.linalg.norm(kept[0].position - pink) > 0.05, columns


def test_a_disc_in_one_view_and_a_long_streak_in_the_other_keep_the_particles_word_along_the_ray():
    """A ball is smeared in every view or in none. A disc in one view and, in the other, that disc merged with a pale
    moving patch beside it (a warm-up ghost of the wall in the streak's colour: lighting tune seed 61, a blob twice the
    ball's length, its centroid 9 pixels off along the epipolar line) triangulate 0.29 m near at 2.4 m. Particles that
    claim 0.15 m along the ray keep their word: only views of one shape place a ball off along its ray."""
    import cv2

    from stereotrack.evidence.gather import CameraEvidence

    rig = default_rig()
    ball = np.array([0.1, 3.0, 0.0])
    masks, _ = disc_masks(rig, ball[None])
    cam = rig.cameras[1]
    (u, v), r = cam.project(ball[None])[0][0], cam.K[0, 0] * RADIUS / cam.depth(ball[None])[0]
    merged = masks[1].copy()
    cv2.rectangle(merged, (int(u - 3 * r), int(v - r)), (int(u), int(v + r)), 1, -1)  # the ghost, left of the ball
    views = (CameraEvidence.from_mask(rig.cameras[0], masks[0]), CameraEvidence.from_mask(cam, merged, foreground=merged))
    assert views[1].blobs.ball_radii()[0] < 0.6 * views[1].blobs.radii[0]  # a long streak in the second view
    ray = (ball - rig.cameras[0].centre) / np.linalg.norm(ball - rig.cameras[0].centre)
    kept, _ = explain([obj(ball, ray, 0.15)], views, ExplainSettings(radius=RADIUS))
    assert len(kept) == 1 and np.linalg.norm(kept[0].position - ball) < 0.01, kept[0].position


def test_the_blobs_two_tracked_balls_overlap_in_and_no_smear_where_a_ball_has_no_blob():
    """_held_twice: per camera, the blobs two or more predicted balls fall in (two balls touching in one blob), not a
    blob one ball holds, nor "no blob" (a ball out of view); _whole: a ball with no blob in a camera (NaN size ratio)
    is no smear there, one whose blob is longer than it is, and np.nan_to_num's reading of them is kept."""
    from stereotrack.objects.explain import STREAK_LONGER, _held_twice, _whole

    rig = default_rig()
    a, b, c = np.array([-0.02, 1.5, 0.0]), np.array([0.02, 1.5, 0.0]), np.array([0.3, 1.5, 0.0])  # a, b touch; c apart
    masks, _ = disc_masks(rig, np.array([a, b, c]))
    views = evidence(rig, masks)
    blobs = [v.blobs for v in views]
    out_of_view = np.array([0.0, -1.0, 0.0])  # behind both cameras
    held = _held_twice(np.array([a, b, c, out_of_view, out_of_view]), rig.cameras, blobs, RADIUS)
    assert [len(s) for s in held] == [1, 1]
    for s, v in zip(held, views):
        (k,) = s
        assert isinstance(k, int) and np.linalg.norm(v.blobs.centres[k] - v.camera.project(a[None])[0][0]) < 20
    assert _held_twice(np.array([a, c]), rig.cameras, blobs, RADIUS) == [set(), set()]
    blob_ids = np.array([[0, -1], [0, 0], [0, 0]])
    log_ratio = np.array([[np.nan, np.nan], [STREAK_LONGER + 0.1, np.inf], [-np.inf, 0.0]])
    got = _whole(blob_ids, [views[0].blobs] * 2, log_ratio)
    fill_only = _whole(blob_ids, [views[0].blobs] * 2, np.zeros_like(log_ratio))
    assert (got == (fill_only | (np.nan_to_num(log_ratio) > STREAK_LONGER))).all()
    assert got[1].all() and not (got[0] & ~fill_only[0]).any()


def test_a_far_balls_blur_of_a_fifth_of_its_width_is_a_short_blur():
    """A far ball blurred to 1.2 times its width (fast_ball tune seed 28: 1.2-1.25 at 16 m, its blob's box 35 % wider
    than the ball) is no clean disc, and was no short blur either (1.3 was asked): its object kept the particles' word,
    0.48 m near at 8 m. A short blur from 1.15 times its width on: its width is the ball's, its centroid triangulates."""
    ball = np.array([0.05, 8.0, 0.0])
    rig, masks, views = _blurred(ball, np.array([0.01, 0.0, 0.0]))
    for v in views:
        (a, b) = v.blobs.axes[0]
        assert 1.15 < a / b < 1.3, (a, b)
    ray = ball / np.linalg.norm(ball)
    off = ball - 0.06 * np.linalg.norm(ball) * ray
    kept, _ = explain([obj(off, ray, 0.19)], views, ExplainSettings(radius=RADIUS))
    assert len(kept) == 1 and kept[0].swept and np.linalg.norm(kept[0].position - ball) < 0.05, kept[0].position


def test_a_small_blur_is_one_wherever_it_falls_on_the_blob_finders_grid():
    """The blob finder labels a subsampled mask and counts a blob's pixels in its box grown by one cell. A small blur
    moving all over must read as moving wherever its rows fall on that grid: counted in the bare box, a blur starting
    on an odd row read 0.65 of its pixels moving, was no short blur, and kept its particles' word 0.4 m off along the
    ray (fast_ball tune seed 29, 0.079 -> 0.936 with the grown box)."""
    for height in (0.0, 0.008):  # the same blur, one pixel lower: its top row on the grid, then off it
        ball = np.array([0.05, 10.0, height])
        rig, masks, views = _blurred(ball, np.array([0.02, 0.0, 0.0]))
        ray = ball / np.linalg.norm(ball)
        off = ball + 0.4 * ray
        kept, _ = explain([obj(off, ray, 0.06)], views, ExplainSettings(radius=RADIUS))
        assert len(kept) == 1 and kept[0].swept, height
        assert np.linalg.norm(kept[0].position - ball) < 0.1, (height, kept[0].position)


def test_a_ball_cut_in_two_pieces_in_every_view_is_one_ball_and_two_touching_balls_stay_two():
    """A white ball whose band of the wall's shade shows nothing is two blobs in each view, its lit top and its shaded
    bottom; each pair triangulates to an object of its own, each explains blobs no other does, and both were kept: two
    tracks on one ball (white_ball tune seeds 91, 223, 233). Two balls' blobs of their own lie a disc or more apart;
    pieces of one ball lie within 1.5 of its radii of each other in every view and cover no more than its disc: they
    are one ball, between the two. A ball and a post beside it, and two balls that touch, stay two."""
    rig = default_rig()
    ball = np.array([0.0, 1.5, 0.0])
    masks, _ = disc_masks(rig, ball[None])
    pieces = []
    for cam, m in zip(rig.cameras, masks):
        (u, v), _ = cam.project(ball[None])[0][0], None
        m[int(v) - 2 : int(v) + 3] = 0  # the band across the ball's middle
        pieces.append([(u, v - 6), (u, v + 6)])  # about where each piece's centroid falls
    views = evidence(rig, masks)
    assert all(len(view.blobs) == 2 for view in views)
    top, bottom = (rig.triangulate([p[k] for p in pieces]) for k in (0, 1))
    kept, into = explain([obj(top, mass=0.3), obj(bottom)], views, ExplainSettings(radius=RADIUS))
    assert len(kept) == 1 and list(into) == [0, 0]
    assert np.linalg.norm(kept[0].position - ball) < 0.01
    # a ball and a thing of its colour beside it in both views (a post behind it): near, but more than one ball's disc
    masks, _ = disc_masks(rig, ball[None])
    posts = []
    for cam, m in zip(rig.cameras, masks):
        (u, v) = cam.project(ball[None])[0][0]
        r = cam.apparent_radius(RADIUS, cam.depth(ball[None]))[0]
        m[int(v - 4 * r) : int(v + 4 * r), int(u + r + 3) : int(u + 1.3 * r + 3)] = 1  # its centroid 1.4 radii off the ball's
        posts.append((u + 1.15 * r + 3, v))
    views = evidence(rig, masks)
    assert all(len(view.blobs) == 2 for view in views)
    kept, _ = explain([obj(ball, mass=0.3), obj(rig.triangulate(posts))], views, ExplainSettings(radius=RADIUS))
    assert len(kept) == 2
    touching = np.array([[-RADIUS, 1.5, 0.0], [RADIUS, 1.5, 0.0]])  # side by side, one diameter apart
    masks, _ = disc_masks(rig, touching, radius=0.9 * RADIUS)  # (drawn a little smaller: two blobs, not one)
    kept, into = explain([obj(p) for p in touching], evidence(rig, masks), ExplainSettings(radius=RADIUS))
    assert len(kept) == 2 and list(into) == [0, 1]


def test_a_ball_seen_by_one_camera_claims_no_better_depth_than_two_would_give():
    """A ball hidden in cam1 is placed on its cam0 ray at the particles' depth, which they claim to 7 cm at any
    distance (ONE_VIEW_DEPTH_SIGMA). At 6 m, 0.3 m of baseline triangulates half-pixel centroids to 0.15 m along the
    ray: a far ball's one-view object claimed half that and pulled its track off (fast_ball tune seed 241, 12.7 m)."""
    from stereotrack.camera import triangulate_with_covariance
    from stereotrack.objects.explain import ONE_VIEW_DEPTH_SIGMA
    from stereotrack.objects.shapes import CENTROID_SIGMA_PX

    rig = default_rig()
    c0 = rig.cameras[0]
    for ball, floor in ((np.array([0.1, 6.0, 0.0]), "stereo"), (np.array([0.1, 1.5, 0.0]), "particles")):
        masks, _ = disc_masks(rig, ball[None])
        masks[1][:] = 0  # hidden in cam1
        ray = (ball - c0.centre) / np.linalg.norm(ball - c0.centre)
        kept, _ = explain([obj(ball, ray, 0.02)], evidence(rig, masks), ExplainSettings(radius=RADIUS))
        assert len(kept) == 1 and np.linalg.norm(kept[0].position - ball) < 0.01
        sigma = np.sqrt(ray @ kept[0].covariance @ ray)
        two = triangulate_with_covariance(rig.cameras, [c.project(ball[None])[0] for c in rig.cameras], CENTROID_SIGMA_PX)[1][0]
        stereo = np.sqrt(ray @ two @ ray)
        if floor == "stereo":
            assert stereo > 2 * ONE_VIEW_DEPTH_SIGMA and sigma >= 0.99 * stereo, (sigma, stereo)
        else:
            assert stereo < ONE_VIEW_DEPTH_SIGMA and abs(sigma - ONE_VIEW_DEPTH_SIGMA) < 1e-6, (sigma, stereo)
