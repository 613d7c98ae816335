import cv2
import numpy as np
import pytest
from scene_helpers import RADIUS, default_rig, disc_masks, evidence

from stereotrack.camera import Camera, Rig, intrinsics_from_fov, look_at
from stereotrack.evidence.blobs import find_blobs
from stereotrack.particles.proposal import depth_range_from_size, particles_on_rays, ray_crossings


def disc_mask(centres, radius, shape=(480, 640)):
    m = np.zeros(shape, np.uint8)
    for c in centres:
        cv2.circle(m, (int(round(c[0])), int(round(c[1]))), radius, 1, -1)
    return m


def test_components_find_each_disc():
    centres = [(100, 100), (300, 100), (100, 300)]  # share a row and a column
    blobs = find_blobs(disc_mask(centres, 10), "components", 6)
    assert len(blobs) == 3
    got = sorted(map(tuple, np.round(blobs.centres).astype(int)))
    assert got == sorted(centres)
    assert np.allclose(blobs.radii, 10.5, atol=1)


def test_histogram_maxima_find_discs_and_drop_empty_ghosts():
    centres = [(100, 100), (300, 100), (100, 300)]
    blobs = find_blobs(disc_mask(centres, 10), "histogram", 6)
    got = {tuple(c) for c in np.round(blobs.centres).astype(int)}
    for c in centres:
        assert any(abs(g[0] - c[0]) <= 1 and abs(g[1] - c[1]) <= 1 for g in got)
    assert len(blobs) == 3  # the (300, 300) ghost has no colour and is dropped


def test_rays_from_blobs_pass_through_the_ball():
    K = intrinsics_from_fov(640, 480, 60)
    R, t = look_at((-0.15, 0, 0), (0, 0, 1.5))
    cam = Camera("cam0", (640, 480), K, np.zeros(5), R, t)
    balls = np.array([[0.1, 0.05, 1.2], [-0.3, -0.1, 2.0]])
    radius = 0.035
    uv, _ = cam.project(balls)
    r_px = [int(round(K[0, 0] * radius / cam.depth(balls)[i])) for i in range(2)]
    mask = disc_mask(uv[:1], r_px[0]) | disc_mask(uv[1:], r_px[1])
    blobs = find_blobs(mask, "components", 6)
    o, d = cam.rays(blobs.centres)
    near, far = depth_range_from_size(cam, blobs.radii, radius, 0.2, 5.0)
    for ball in balls:
        v = ball - o
        dist = np.linalg.norm(v - (v * d).sum(1, keepdims=True) * d, axis=1)
        i = int(np.argmin(dist))
        assert dist[i] < 0.005  # the ray passes within 5 mm of the ball centre
        along = float(v[i] @ d[i])
        assert near[i] < along < far[i]  # the size-based range keeps the true distance
    rng = np.random.default_rng(0)
    pts, ray = particles_on_rays(o, d, near, far, 1001, rng)
    assert len(pts) == 1001 and abs(np.bincount(ray)[0] - np.bincount(ray)[1]) <= 1


def test_ray_crossings_find_each_ball_and_skip_blobs_of_the_wrong_size():
    rig = default_rig()
    balls = np.array([[-0.2, 1.2, 0.1], [0.1, 1.6, -0.1], [0.3, 2.2, 0.1]])  # apart in both views
    masks, _ = disc_masks(rig, balls)
    crossings = ray_crossings(evidence(rig, masks), RADIUS, 0.2, 5.0)
    for ball in balls:
        assert np.linalg.norm(crossings - ball, axis=1).min() < 0.01
    assert len(crossings) < 9  # fewer than every pair: ghosts off the epipolar lines or of the wrong size are gone
    # The same three balls drawn five times too large (a poster, not a ball at that depth): no crossing.
    posters, _ = disc_masks(rig, balls, radius=5 * RADIUS)
    assert len(ray_crossings(evidence(rig, posters), RADIUS, 0.2, 5.0)) == 0


def test_crossings_skip_the_blob_a_tracked_ball_holds_when_seeds_are_fewer_than_blobs(monkeypatch):
    """The held flags go to the blobs the crossings are made from, not to the seeds (a subset of them when
    only ball-like or moving blobs seed): a flag shifted onto another blob kept the tracked ball's crossing,
    and the kernel read flags past the short array (garbage memory: runs of one recording differed)."""
    from dataclasses import replace

    from scene_helpers import balls_at

    from stereotrack.config import TrackerSettings
    from stereotrack.evidence.gather import Seeds
    from stereotrack.particles import proposal

    rig = default_rig()
    balls = np.array([[-0.2, 1.2, 0.1], [0.1, 1.6, -0.1], [0.3, 2.2, 0.1]])
    masks, _ = disc_masks(rig, balls)
    views = []
    for v in evidence(rig, masks):
        assert len(v.blobs) == 3
        first = int(np.argmin(v.blobs.centres[:, 1] * 1e4 + v.blobs.centres[:, 0]))  # leave out one blob: seeds are a subset
        keep = np.arange(3) != first
        views.append(replace(v, seeds=Seeds(v.blobs.centres[keep], v.blobs.radii[keep], v.origins[keep], v.directions[keep])))
    # the tracked ball: one whose blob is a seed in both views
    uv = [cam.project(balls)[0] for cam in rig.cameras]
    seeded = [i for i in range(3) if all(np.linalg.norm(u[i] - v.seeds.centres, axis=1).min() < 1 for u, v in zip(uv, views))]
    assert seeded
    tracked = seeded[0]
    made = []

    def spy(*args, **kwargs):
        made.append(ray_crossings(*args, **kwargs))
        return made[-1]

    monkeypatch.setattr(proposal, "ray_crossings", spy)
    rp = proposal.RayProposal(TrackerSettings(), RADIUS)
    rp(views, 400, balls_at(balls[tracked : tracked + 1]), np.random.default_rng(0))
    crossings = made[-1]
    assert np.linalg.norm(crossings - balls[tracked], axis=1).min(initial=np.inf) > 0.01  # the tracked ball's blobs make none
    for i in range(3):
        if i != tracked:  # every untracked ball's blobs still cross
            assert np.linalg.norm(crossings - balls[i], axis=1).min() < 0.01


def test_ray_crossings_refuse_skip_flags_that_are_not_one_per_blob():
    rig = default_rig()
    masks, _ = disc_masks(rig, np.array([[-0.2, 1.2, 0.1], [0.1, 1.6, -0.1]]))
    views = evidence(rig, masks)
    with pytest.raises(ValueError, match="one flag per blob"):
        ray_crossings(views, RADIUS, 0.2, 5.0, [np.zeros(1, bool), np.zeros(2, bool)])


def test_a_moving_blob_among_a_hundred_specks_gets_its_share_of_the_particles_at_the_ball_s_depth():
    """A white ball on a white wall: one blob of the moving map among a hundred specks of the colour mask. A fair
    share per ray left it a few particles; it gets proposal.MOVING_SHARE of them. Its blob is twice the ball's size
    (a slow ball's trail), and its depth range still reaches the ball."""
    from dataclasses import replace

    from stereotrack.config import TrackerSettings
    from stereotrack.evidence.gather import Seeds
    from stereotrack.particles.proposal import MOVING_SHARE, RayProposal

    rig = default_rig()
    ball = np.array([0.1, 1.6, -0.1])
    rng = np.random.default_rng(3)
    views = []
    for cam, v in zip(rig.cameras, evidence(rig, disc_masks(rig, ball[None])[0])):
        (uv,), _, (z,) = cam.view(ball[None])
        specks = rng.uniform((20, 20), (620, 460), (100, 2))
        centres = np.vstack([specks, uv[None]])
        radii = np.r_[np.full(100, 2.0), 2 * cam.apparent_radius(RADIUS, z)]  # the trail doubles the moving blob
        o, d = cam.rays(centres)
        views.append(replace(v, seeds=Seeds(centres, radii, o, d, np.r_[np.zeros(100, bool), True])))
    n = 1000
    pts = RayProposal(TrackerSettings(crossing_share=0.0), RADIUS, moving_first=True)(views, n, None, np.random.default_rng(0))
    assert len(pts) == n
    near = np.linalg.norm(pts - ball, axis=1) < RADIUS
    # about half of them go along the ball's two rays (one per camera), spread over its depth range: some hit the ball
    on_rays = sum(np.linalg.norm(cam.project(pts)[0] - cam.project(ball[None])[0], axis=1) < 1.0 for cam in rig.cameras)
    assert on_rays.sum() >= MOVING_SHARE * n - 2
    assert near.sum() >= 5
    # a ball of one hue is a colour blob: its shares stay fair
    pts = RayProposal(TrackerSettings(crossing_share=0.0), RADIUS)(views, n, None, np.random.default_rng(0))
    assert sum(np.linalg.norm(cam.project(pts)[0] - cam.project(ball[None])[0], axis=1) < 1.0 for cam in rig.cameras).sum() < 50


def test_a_white_ball_s_crossings_are_its_moving_blobs_only():
    """The specks of a white wall's colour cross everywhere; for a ball of every hue only blobs with moving
    pixels make crossings (a ball of one hue keeps every blob's)."""
    import cv2

    from stereotrack.config import TrackerSettings
    from stereotrack.evidence.gather import CameraEvidence
    from stereotrack.particles.proposal import RayProposal

    rig = default_rig()
    balls = np.array([[-0.2, 1.2, 0.1], [0.1, 1.6, -0.1]])  # the first moves, the second is a still patch of the colour
    masks, _ = disc_masks(rig, balls)
    views = []
    for cam, m in zip(rig.cameras, masks):
        (uv,), _, (z,) = cam.view(balls[:1])
        fg = np.zeros((m.shape[0] // 2, m.shape[1] // 2), np.uint8)
        cv2.circle(fg, (int(uv[0] / 2), int(uv[1] / 2)), int(cam.apparent_radius(RADIUS, z) / 2), 1, -1)
        views.append(CameraEvidence.from_mask(cam, m, foreground=fg))
    settings = TrackerSettings(crossing_share=1.0)
    pts = RayProposal(settings, RADIUS, moving_first=True)(views, 400, None, np.random.default_rng(0))
    assert (np.linalg.norm(pts - balls[0], axis=1) < 3 * RADIUS).sum() > 300
    assert (np.linalg.norm(pts - balls[1], axis=1) < 3 * RADIUS).sum() == 0
    pts = RayProposal(settings, RADIUS)(views, 400, None, np.random.default_rng(0))
    assert (np.linalg.norm(pts - balls[1], axis=1) < 3 * RADIUS).sum() > 100


def test_the_tracked_balls_are_projected_once_a_camera_for_the_seeds_and_the_crossings(monkeypatch):
    """Both uses of which blobs a tracked ball holds (the seeds' sizes, the crossings left out) read one projection of
    the tracked balls per camera: they were projected twice a camera every frame."""
    from scene_helpers import balls_at

    from stereotrack.config import TrackerSettings
    from stereotrack.particles import proposal

    rig = default_rig()
    balls = np.array([[-0.2, 1.2, 0.1], [0.1, 1.6, -0.1], [0.3, 2.2, 0.1]])
    masks, _ = disc_masks(rig, balls)
    views = evidence(rig, masks)
    projected = []
    project = Camera.project
    monkeypatch.setattr(Camera, "project", lambda self, points: projected.append(self.name) or project(self, points))
    pts = proposal.RayProposal(TrackerSettings(), RADIUS)(views, 400, balls_at(balls[:1]), np.random.default_rng(0))
    assert len(pts) == 400 and sorted(projected) == sorted(cam.name for cam in rig.cameras)


def sphere_masks(rig, path: np.ndarray, radius: float = RADIUS):
    """Per camera: a 0/1 mask of a ball's true image as it moves along ``path`` during the exposure (the union of the
    sphere's projected outlines at each point: off the camera's axis an ellipse stretched away from the centre)."""
    on_sphere = np.random.default_rng(0).normal(size=(2000, 3))
    on_sphere /= np.linalg.norm(on_sphere, axis=1, keepdims=True)
    masks = []
    for cam in rig.cameras:
        m = np.zeros((cam.height, cam.width), np.uint8)
        for centre in path:
            uv, _ = cam.project(centre + radius * on_sphere)
            cv2.fillConvexPoly(m, cv2.convexHull(np.round(uv * 16).astype(np.int32)), 1, shift=4)
        masks.append(m)
    return masks


def proposed_moving_and_still(monkeypatch, rig, masks, ball):
    """Per camera's ``masks`` seen moving (True) and still (False): the proposal's crossings, and which of its 400
    particles lie within two radii of ``ball``."""
    from stereotrack.config import TrackerSettings
    from stereotrack.evidence.gather import CameraEvidence
    from stereotrack.particles import proposal
    from stereotrack.particles.proposal import RayProposal

    made = []

    def spy(*args, **kwargs):
        made.append(ray_crossings(*args, **kwargs))
        return made[-1]

    monkeypatch.setattr(proposal, "ray_crossings", spy)
    found = {}
    for moving in (True, False):
        views = [CameraEvidence.from_mask(cam, m, foreground=m * moving) for cam, m in zip(rig.cameras, masks)]
        assert all(len(v.blobs) == 1 for v in views)
        pts = RayProposal(TrackerSettings(d_min=0.2, d_max=5.0), RADIUS)(views, 400, None, np.random.default_rng(0))
        found[moving] = (made[-1], np.linalg.norm(pts - ball, axis=1) < 2 * RADIUS)
    return found


def test_a_moving_ball_near_the_edge_of_a_wide_view_keeps_its_crossing_and_its_particles(monkeypatch):
    """Off the camera's axis a ball's image is stretched away from the centre (1 / cos of its ray's angle, 1.2-1.3 here
    in a 90-degree view), and a short blur stretches it more; its blob's larger side is then 1.6-1.8 times a ball's
    width there. Read as the ball's size, that put it too near: no crossing, and a depth range that ended before the
    ball (fast_ball tune seed 407: 6 frames of a clearly seen ball with no particle on it). A moving blob is read off
    the axis now; a still one (a patch of a wall of the ball's hue at the image's edge) as before."""

    K = intrinsics_from_fov(640, 480, 90.0)
    cams = []
    for i, x in enumerate((-0.15, 0.15)):
        R, t = look_at((x, 0.0, 0.0), (0.0, 1.5, 0.0), up=(0.0, 0.0, 1.0))
        cams.append(Camera(f"cam{i}", (640, 480), K, np.zeros(5), R, t))
    rig = Rig(tuple(cams), world="custom")
    ball = np.array([-1.5, 2.0, 0.3])
    path = ball + np.linspace(-0.015, 0.015, 9)[:, None] * np.array([1.0, 0.0, 0.0])  # 3 cm of motion in the exposure
    masks = sphere_masks(rig, path)
    for cam, m in zip(rig.cameras, masks):
        (_, _, w, h), ball_px = cv2.boundingRect(m), cam.focal_px * RADIUS / cam.depth(ball[None])[0]
        assert max(w, h) / 2 > 1.6 * ball_px  # beyond the slack a ball's size has on the camera's axis
    found = proposed_moving_and_still(monkeypatch, rig, masks, ball)
    crossings, near = found[True]
    assert len(crossings) == 1 and np.linalg.norm(crossings[0] - ball) < 0.01
    assert near.sum() > 50  # the crossing's share and its rays' particles
    crossings, near = found[False]
    assert len(crossings) == 0 and near.sum() == 0  # a still blob of that size is no ball there


def test_a_fast_ball_whose_streak_reads_narrower_than_the_ball_keeps_its_crossing_and_its_particles(monkeypatch):
    """A fast ball's blur fades at the streak's sides, and the faded edges fall out of its mask: the streak's width
    reads narrower than the ball (fast_ball tune seed 422: 1.9 px against a ball of 4). Read as the ball's size, that
    put it too far: the crossing test refused the pair, and the depth range along its ray began beyond the ball. A
    moving streak's length says the ball is there now; a still blob that thin is no ball there, as before."""
    from stereotrack.config import TrackerSettings
    from stereotrack.evidence.gather import CameraEvidence
    from stereotrack.particles.proposal import RayProposal

    rig = default_rig()
    ball = np.array([0.1, 2.0, 0.1])
    path = ball + np.linspace(-0.1, 0.1, 21)[:, None] * np.array([1.0, 0.0, 0.3])  # 20 cm of flight in the exposure
    masks = sphere_masks(rig, path, 0.35 * RADIUS)  # the streak's bright core only
    views = [CameraEvidence.from_mask(cam, m, foreground=m) for cam, m in zip(rig.cameras, masks)]
    for cam, v in zip(rig.cameras, views):  # narrower than the ball beyond the slack its size has
        assert len(v.blobs) == 1 and v.blobs.ball_radii()[0] < cam.apparent_radius(RADIUS, cam.depth(ball[None])[0]) / 1.6
    found = proposed_moving_and_still(monkeypatch, rig, masks, ball)
    crossings, near = found[True]
    assert len(crossings) == 1 and np.linalg.norm(crossings[0] - ball) < 0.02
    assert near.sum() > 50  # the crossing's share and its rays' particles
    crossings, near = found[False]
    assert len(crossings) == 0
    # without the crossing's share, the streak's rays alone still reach the ball (their depth range began beyond it)
    settings = TrackerSettings(d_min=0.2, d_max=5.0, crossing_share=0.0)
    pts = RayProposal(settings, RADIUS)(views, 400, None, np.random.default_rng(0))
    assert (np.linalg.norm(pts - ball, axis=1) < 2 * RADIUS).sum() >= 5


def test_a_ball_moving_before_a_wall_of_its_colour_crosses_from_its_moving_blobs_a_moving_band_does_not(monkeypatch):
    """A ball before a wall of its hue: in the colour mask its disc joins the wall's blob, far too large for a ball, which
    crosses nothing; in the moving map it is a blob of its own, and its rays in the two views cross at the ball (hue_wall
    tune seed 115: two balls moving before a curtain of their hue had no crossing, and were found after 13 and 29
    frames). So it does where only its rim moves, its middle matching the wall behind it: round, filling about half of
    its disc (tune seeds 95, 74: found after 27 and 35 frames; gather.ROUND_ALONE_FILL). A band of a ball's size along a
    moving edge (a hand's: a crescent, longer than wide and filling little of its ellipse) seeds particles along its rays
    but crosses nothing (gather.ALONE_FILL)."""
    from stereotrack.config import TrackerSettings
    from stereotrack.evidence.gather import CameraEvidence
    from stereotrack.particles import proposal

    rig = default_rig()
    ball = np.array([[0.1, 1.6, -0.1]])
    discs, _ = disc_masks(rig, ball)
    made = []

    def spy(*args, **kwargs):
        made.append(ray_crossings(*args, **kwargs))
        return made[-1]

    monkeypatch.setattr(proposal, "ray_crossings", spy)
    for moving_part, crosses in (("disc", True), ("rim", True), ("band", False)):
        views = []
        for cam, disc in zip(rig.cameras, discs):
            x, y = cam.project(ball)[0][0]
            r = cam.apparent_radius(RADIUS, cam.depth(ball))[0]
            wall = np.zeros_like(disc)
            wall[:, int(x) + 2 :] = 1  # the wall of its colour, from inside the ball's disc to the image's right edge
            moving = disc.copy()
            if moving_part == "rim":
                cv2.circle(moving, (round(x), round(y)), int(0.6 * r), 0, -1)
            elif moving_part == "band":
                cv2.circle(moving, (round(x + 0.5 * r), round(y)), round(r), 0, -1)
            views.append(CameraEvidence.from_mask(cam, disc | wall, foreground=moving, ball=(RADIUS, 0.2, 5.0)))
            assert len(views[-1].blobs) == 1  # the ball and the wall: one blob of the mask
        assert not len(ray_crossings(views, RADIUS, 0.2, 5.0))  # (which crosses nowhere)
        assert all(v.seeds is not None and len(v.seeds) == 1 for v in views)  # the moving blob seeds, whatever its shape
        made.clear()
        proposal.RayProposal(TrackerSettings(), RADIUS)(views, 400, None, np.random.default_rng(0))
        nearest = min((np.linalg.norm(c - ball, axis=1).min(initial=np.inf) for c in made), default=np.inf)
        assert nearest < 0.01 if crosses else nearest > 0.05, moving_part


def test_crossings_of_moving_blobs_of_their_own_get_particles_of_their_own():
    """The mask's crossings keep crossing_share of the abductive particles whatever else crosses: the moving blobs' own
    crossings get ALONE_EACH each besides, from the rays' part, at most a quarter of them all (or the share, when the
    mask crosses nowhere); and ray_crossings gives those alone, not the mask's pairs again."""
    from stereotrack.evidence.gather import CameraEvidence
    from stereotrack.particles.proposal import ALONE_EACH, alone_particles

    assert alone_particles(400, 0.25, 5, 0) == 0
    assert alone_particles(400, 0.25, 0, 3) == 100  # moving blobs' alone: the share
    assert alone_particles(400, 0.25, 60, 3) == 3 * ALONE_EACH  # a wall's many crossings do not thin them out
    assert alone_particles(400, 0.25, 60, 40) == 100  # at most a quarter
    assert alone_particles(400, 0.9, 60, 30) == 400 - 360  # nor more than the share leaves the rays
    assert alone_particles(400, 1.0, 60, 3) == 0
    rig = default_rig()
    balls = np.array([[-0.2, 1.5, 0.0], [0.2, 1.8, 0.05]])
    discs, _ = disc_masks(rig, balls)
    views = [CameraEvidence.from_mask(cam, d) for cam, d in zip(rig.cameras, discs)]
    mask_only = ray_crossings(views, RADIUS, 0.2, 5.0)
    assert len(mask_only) >= 2  # the two balls (and their ghosts, if any)
    # the second ball's disc again as another map's ray in camera 1: it crosses camera 0's blobs, not the mask's pairs
    v = views[1]
    k = int(np.argmin(np.linalg.norm(v.blobs.centres - rig.cameras[1].project(balls[1:])[0], axis=1)))
    more = [
        (np.zeros((0, 3)), np.zeros((0, 3)), np.zeros(0), np.zeros(0), np.zeros(0, bool)),
        (v.rays[0][k : k + 1], v.rays[1][k : k + 1], v.blobs.ball_radii()[k : k + 1], np.zeros(1), np.ones(1, bool)),
    ]
    extra = ray_crossings(views, RADIUS, 0.2, 5.0, more=more)
    assert np.linalg.norm(extra - balls[1], axis=1).min() < 0.01
    origin, direction = more[1][0][0], more[1][1][0]
    off_ray = np.linalg.norm(np.cross(extra - origin, direction), axis=1)
    assert (off_ray < RADIUS).all()  # each on the other map's ray: none of the mask's own pairs (ball 0's crossing)
    assert np.linalg.norm(mask_only - balls[0], axis=1).min() < 0.01
