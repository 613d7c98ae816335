"""A fast ball's streak: its colour, mixed with the background it swept over, is paler than the typed range."""

import cv2
import numpy as np
from scene_helpers import RADIUS, default_rig

from stereotrack.config import Target
from stereotrack.evidence.colour import camera_masks, range_bounds, streak_range
from stereotrack.evidence.gather import CameraEvidence, Faint
from stereotrack.evidence.motion import BackgroundModel, halved

PALE_BLUE = cv2.cvtColor(np.uint8([[[108, 60, 170]]]), cv2.COLOR_HSV2BGR)[0, 0].tolist()  # saturation 60 < the range's 80
BLUE = cv2.cvtColor(np.uint8([[[118, 200, 170]]]), cv2.COLOR_HSV2BGR)[0, 0].tolist()


def _moving_view(draw):
    """The moving evidence of a blue target on a grey wall after 20 calm frames, with ``draw`` painted in the last."""
    cam = default_rig().cameras[0]
    blue = Target("blue", (108, 80, 80), (128, 255, 255), RADIUS)
    bg = BackgroundModel(cam, rate=0.05, threshold=30)
    rng = np.random.default_rng(7)

    def wall():
        return np.clip(np.full((cam.height, cam.width, 3), 200.0) + rng.normal(0, 2, (cam.height, cam.width, 3)), 0, 255).astype(np.uint8)

    for _ in range(20):
        bg.update(wall())
    image = wall()
    draw(image)
    fg = bg.update(image)
    cm = camera_masks(cam.name, image, (blue,), integrals=False)
    view = CameraEvidence.from_mask(cam, cm.masks["blue"], foreground=fg, streak_range=streak_range(blue), hsv=cm.hsv)
    return cm, view


def test_a_pale_moving_streak_is_evidence_and_a_pale_moving_disc_or_rim_is_not():
    """A far fast ball (saturation 60 against a typed 80): no pixel in range, but moving and shaped like a streak, so
    the moving map holds it and it seeds particles at its width's depth. A pale moving disc is no streak, and a pale
    streak-shaped sliver beside a ball in range is that ball's edge: neither enters."""
    cm, view = _moving_view(lambda img: cv2.line(img, (200, 240), (236, 246), PALE_BLUE, 6))
    assert cm.masks["blue"].sum() == 0
    assert view.moving[243, 218] == 1 and view.moving.sum() > 150
    assert len(view.seeds) == 1 and abs(view.seeds.widths[0] - 3) < 1.5  # its width, not its length
    _, disc = _moving_view(lambda img: cv2.circle(img, (218, 243), 9, PALE_BLUE, -1))
    assert disc.moving.sum() == 0

    def ball_and_sliver(img):
        cv2.circle(img, (300, 240), 14, BLUE, -1)
        cv2.line(img, (320, 226), (320, 254), PALE_BLUE, 4)

    _, rim = _moving_view(ball_and_sliver)
    assert rim.moving[240, 320] == 0 and rim.moving[240, 300] == 1


def test_the_streak_range_widens_hue_and_saturation_and_wraps_around_red():
    red = streak_range(Target("red", (172, 100, 90), (8, 255, 255), RADIUS))
    assert red.hsv_min == (162, 40, 45) and red.hsv_max == (18, 255, 255) and red.wraps
    wide = streak_range(Target("any", (10, 90, 90), (175, 255, 255), RADIUS))
    assert wide.hsv_min[0] == 0 and wide.hsv_max[0] == 179


LAVENDER = (205.0, 180.0, 190.0)  # BGR: a wall of about the complementary colour of a yellow-green ball
YELLOW_GREEN = cv2.cvtColor(np.uint8([[[40, 200, 200]]]), cv2.COLOR_HSV2BGR)[0, 0].astype(float)


SPECK = (200, 240), (207, 240)  # a streak-shaped speck of a few faint cells (noise, hands tune seed 19)


def _faint_view(share: float, colour=YELLOW_GREEN, wall=LAVENDER, shape="streak", faint: bool = True, ghost: bool = False):
    """The evidence of a yellow-green target on a lavender wall after 20 calm frames, with a far fast ball's streak in
    the last: the wall and the ball mixed, the ball ``share`` of the exposure (drawn as a 4-pixel-wide line, or a disc).
    ``ghost``: the streak is in the frame before the last too (a streak's place is new each frame)."""
    cam = default_rig().cameras[0]
    target = Target("ball", (30, 80, 80), (50, 255, 255), RADIUS)
    bg = BackgroundModel(cam, rate=0.05, threshold=30, faint=faint)
    rng = np.random.default_rng(11)

    def room():
        return np.clip(np.array(wall)[None, None] + rng.normal(0, 2, (cam.height, cam.width, 3)), 0, 255).astype(np.uint8)

    mixed = (np.array(wall) + share * (np.asarray(colour, float) - np.array(wall))).tolist()

    def scene():
        image = room()
        if shape == "streak":
            cv2.line(image, (200, 240), (240, 244), mixed, 4)
        elif shape == "speck":
            cv2.line(image, *SPECK, mixed, 2)
        elif shape == "dot":  # a couple of faint cells
            cv2.line(image, SPECK[0], SPECK[0], mixed, 2)
        else:
            cv2.circle(image, (220, 242), 8, mixed, -1)
        return image

    for _ in range(20):
        bg.update(room())
    if ghost:
        bg.update(scene())
    image = scene()
    small = halved(image)
    fg = bg.update(image, image_halved=small)
    cm = camera_masks(cam.name, image, (target,), integrals=False)
    extra = Faint(bg.faint, small, bg.behind, range_bounds(target)) if faint else None
    return CameraEvidence.from_mask(cam, cm.masks["ball"], foreground=fg, streak_range=streak_range(target), hsv=cm.hsv, faint=extra)


def test_a_faint_streak_that_mixes_to_grey_is_evidence_and_a_faint_disc_or_shadow_is_not():
    """A far fast ball's streak on a wall of about its complementary colour: the mix is grey (no pixel in the streak
    range) and differs from the wall by less than the threshold (no moving pixel), but it differs by more than the
    faint share of it, and the change points from the wall to the ball's range: the moving map holds it and it seeds
    particles at its width's depth (fast_ball tune seed 17). Without the faint map it is not there; a faint disc of the
    same colour is no streak, a faint grey streak (a shadow: the change points to black) is not the ball's, and one
    that was there in the frame before too is no fast ball (a ghost: the wall where the background still holds the
    first frame's streak, motion_blur tune seed 0)."""
    share = 0.09  # the streak differs from the wall by 21 grey levels (three channels): under the threshold's 30
    assert 15 < share * np.abs(YELLOW_GREEN - LAVENDER).sum() < 25
    view = _faint_view(share)
    assert view.mask.sum() == 0
    assert view.moving[242, 220] == 1 and view.moving.sum() > 80
    assert len(view.seeds) == 1 and abs(view.seeds.widths[0] - 2) < 1.5
    assert _faint_view(share, faint=False).moving.sum() == 0
    assert _faint_view(share, shape="disc").moving.sum() == 0
    assert _faint_view(0.035, colour=(0.0, 0.0, 0.0)).moving.sum() == 0
    assert _faint_view(share, ghost=True).moving.sum() == 0  # unchanged since the frame before


def test_a_faint_cell_whose_change_points_to_another_targets_colour_is_no_streak():
    """An orange ball's rim over a wall, pale and reddish, lies in a pink ball's streak range; its change from the wall
    points to orange (tests/pipeline/test_tracker.py's crossing: it pulled the pink ball's blob in the view the orange one
    hid it in). With the orange target's range among the others, only the pink streak's cell stays (marks 2: changed
    from the frame before)."""
    from stereotrack.evidence.blob_kernels import pale_cells
    from stereotrack.simulation.spec import BallSpec, RigSpec, SceneSpec
    from stereotrack.simulation.trajectories import Line

    line = Line((0.0, 1.5, 0.0), (0.1, 1.5, 0.0), period=4.0)
    spec = SceneSpec("two", (BallSpec(line, colour="orange"), BallSpec(line, colour="pink")), RigSpec(), 30.0, 2)
    targets = {t.name: t for t in spec.config().targets}
    pink, orange = targets["pink"], targets["orange"]
    behind = np.uint8([[[100, 85, 89], [120, 120, 120]]])  # a greyish wall
    image = np.uint8([[[86, 89, 110], [129, 102, 153]]])  # the orange rim; 0.3 of a pink ball over the grey
    faint = np.full((1, 2), 2, np.uint8)
    out = np.zeros_like(faint)
    pale_cells(faint, image, behind, range_bounds(streak_range(pink)), range_bounds(pink), np.zeros((0, 7), np.int64), out)
    assert out.tolist() == [[2, 2]]  # both could be a pink streak ...
    pale_cells(faint, image, behind, range_bounds(streak_range(pink)), range_bounds(pink), range_bounds(orange)[None], out)
    assert out.tolist() == [[0, 2]]  # ... but the rim's change is orange's


def test_a_faint_speck_of_a_few_cells_is_no_streak(monkeypatch):
    """A streak-shaped speck of faint cells that unmix to the ball's colour is noise (hands tune seed 19: two such cells
    by a hand seeded a false track); a far fast ball's faint streak covers dozens of cells (fast_ball tune seeds 14, 17)."""
    from stereotrack.evidence import gather

    assert _faint_view(0.09, shape="speck").moving.sum() == 0
    monkeypatch.setattr(gather, "FAINT_MIN_CELLS", 0)
    assert _faint_view(0.09, shape="speck").moving.sum() > 0  # what the rule takes out


def test_a_faint_change_over_a_wall_of_a_streaks_colour_is_no_streak_by_its_colour():
    """A pale pink wall lies in a pink ball's streak range: a faint change there (the ghost of the streak the frame
    before, which the background learnt in part: motion_blur tune seed 15) is of a streak's colour whatever it is. Only
    a cell whose background is not of that colour tells a streak by its colour."""
    from stereotrack.evidence.blob_kernels import pale_cells
    from stereotrack.simulation.spec import BallSpec, RigSpec, SceneSpec
    from stereotrack.simulation.trajectories import Line

    line = Line((0.0, 1.5, 0.0), (0.1, 1.5, 0.0), period=4.0)
    pink = SceneSpec("one", (BallSpec(line, colour="pink"),), RigSpec(), 30.0, 2).config().targets[0]
    streak = range_bounds(streak_range(pink))
    behind = np.uint8([[[170, 140, 190], [120, 120, 120], [120, 120, 120]]])  # a pale pink wall; a grey one
    # a faint change of the pink wall; 0.3 of a pink ball over grey; the pink wall's colour over grey
    image = np.uint8([[[176, 146, 197], [129, 102, 153], [176, 146, 197]]])
    faint = np.full((1, 3), 2, np.uint8)
    out = np.zeros_like(faint)
    pale_cells(faint, image, behind, streak, range_bounds(pink), np.zeros((0, 7), np.int64), out)
    assert out.tolist() == [[0, 2, 2]]  # the wall's colour is a streak's: over grey it would be one


def test_a_faint_speck_too_small_for_a_streak_is_not_labelled(monkeypatch):
    """The faint pass labels the pale pixels' blobs only when enough of them are new for a streak to keep
    FAINT_MIN_CELLS cells' worth: the speck's few pixels are no streak whatever their blobs are (the pass labelled
    them in every frame with any pale cell: demo's step 9.4-9.7 -> 10.3-10.8 ms)."""
    from stereotrack.evidence import gather

    labelled = []
    kept = gather._kept_streaks

    def counted(moving, in_range, min_blob_area, rows, known=None, *more):
        labelled.append(known is not None)  # the faint pass's call (_streaks_only's has no known map)
        return kept(moving, in_range, min_blob_area, rows, known, *more)

    monkeypatch.setattr(gather, "_kept_streaks", counted)
    assert _faint_view(0.09, shape="dot").moving.sum() == 0
    assert not any(labelled)
    assert _faint_view(0.09).moving.sum() > 0 and any(labelled)  # a streak is still looked for


def test_faint_pixels_reads_the_cells_as_the_nearest_neighbour_upscaling_does():
    """blob_kernels.faint_pixels: the marked cells at the image's size (cv2.resize's INTER_NEAREST), OR the moving map,
    and the count of those neither in range nor moving, on grids of whole and odd ratios."""
    from stereotrack.evidence.blob_kernels import faint_pixels
    from stereotrack.evidence.gather import _nearest

    rng = np.random.default_rng(3)
    for (ch, cw), (h, w) in [((240, 320), (480, 640)), ((180, 320), (360, 640)), ((7, 11), (15, 23)), ((5, 9), (5, 9))]:
        cells = (rng.random((ch, cw)) < 0.05).astype(np.uint8) * rng.integers(1, 3, (ch, cw), dtype=np.uint8)
        cells[: ch // 2] = 0  # rows without a mark are not read
        in_range = (rng.random((h, w)) < 0.1).astype(np.uint8)
        moving = (rng.random((h, w)) < 0.1).astype(np.uint8)
        rows = np.zeros(h, np.uint8)
        pale = moving.copy()
        new = faint_pixels(cells, _nearest(ch, h), _nearest(cw, w), in_range, moving, pale, rows)
        marks = cv2.resize(cells, (w, h), interpolation=cv2.INTER_NEAREST) > 0
        assert np.array_equal(pale, (marks | (moving > 0)).astype(np.uint8))
        assert new == np.count_nonzero(marks & (in_range == 0) & (moving == 0))
        assert np.array_equal(rows, marks.any(axis=1).astype(np.uint8))


def _candidates_by_labelling(mask, rows, in_range, before, marks, min_area, least):
    """streak_candidates' answer the slow way: OpenCV's 8-connected components of the subsampled mask (rows marked 0
    read as empty), and per component its pixels' shares, as gather._kept_streaks tests them (all but the shape)."""
    from stereotrack.evidence.gather import FRESH_SHARE, KNOWN_SHARE

    small = mask[::2, ::2].copy()
    if len(rows):
        small[rows[::2][: small.shape[0]] == 0] = 0
    n, labels = cv2.connectedComponents(small, connectivity=8)
    cell_of = np.kron(labels, np.ones((2, 2), np.int32))[: mask.shape[0], : mask.shape[1]]
    for c in range(1, n):
        ys, xs = np.nonzero((cell_of == c) & (mask > 0))
        cy, cx = np.nonzero(labels == c)
        inside = cx.min() > 0 and cy.min() > 0 and cx.max() + 1 < small.shape[1] and cy.max() + 1 < small.shape[0]
        if len(cy) * 4 < min_area or not inside:
            continue
        paler = np.count_nonzero(in_range[ys, xs] == 0)
        if paler / max(len(ys), 1) <= 0.5 or paler < least:
            continue
        if before is not None:
            known = np.count_nonzero((before[ys, xs] > 0) | (in_range[ys, xs] > 0))
            fresh = np.count_nonzero(marks[0][marks[1][ys], marks[2][xs]] == 2)
            if known > KNOWN_SHARE * len(ys) or fresh < FRESH_SHARE * len(ys):
                continue
        return True
    return False


def test_the_streak_candidates_are_what_labelling_the_map_finds():
    """blob_kernels.streak_candidates (gather._could_keep) against OpenCV's components of the subsampled map: a blob mostly
    pale (and mostly new and fresh, for the faint pass) away from the edge, on maps of even and odd sizes, with rows
    said empty, for both calls."""
    from stereotrack.evidence.gather import _could_keep, _nearest

    rng = np.random.default_rng(5)
    answers = []
    for trial in range(120):
        h, w = [(60, 80), (61, 83), (48, 64), (37, 45)][trial % 4]
        mask = np.zeros((h, w), np.uint8)
        in_range = np.zeros((h, w), np.uint8)
        for _ in range(rng.integers(1, 5)):  # discs and streaks, some in range, some pale, some half and half
            x, y = int(rng.integers(0, w)), int(rng.integers(0, h))
            if rng.random() < 0.5:
                cv2.circle(mask, (x, y), int(rng.integers(2, 7)), 1, -1)
            else:
                cv2.line(mask, (x, y), (x + int(rng.integers(-20, 20)), y + int(rng.integers(-8, 8))), 1, int(rng.integers(1, 4)))
            cv2.circle(in_range, (x + int(rng.integers(-4, 5)), y), int(rng.integers(0, 6)), 1, -1)
        in_range &= (rng.random((h, w)) < 0.9).astype(np.uint8)
        mask |= in_range & (rng.random((h, w)) < 0.5).astype(np.uint8)
        rows = mask.max(axis=1) if trial % 3 else np.zeros(0, np.uint8)
        if trial % 5 == 0 and len(rows):
            rows[rng.integers(0, h, 4)] = 0  # rows said empty are not read
        before = marks = None
        least = int(rng.integers(0, 12))
        if trial % 2:
            before = mask & (rng.random((h, w)) < 0.3).astype(np.uint8)
            cells = rng.integers(0, 3, ((h + 1) // 2, (w + 1) // 2)).astype(np.uint8)
            marks = (cells, _nearest(cells.shape[0], h), _nearest(cells.shape[1], w))
        expected = _candidates_by_labelling(mask, rows, in_range, before, marks, 6, least)
        assert _could_keep(mask, in_range, 6, rows if len(rows) else None, before, marks, least) == expected
        answers.append(expected)
    assert 10 < sum(answers) < len(answers) - 10  # both answers were asked for


def test_a_moving_balls_pale_rim_is_not_labelled_and_a_pale_streak_still_is(monkeypatch):
    """The streak checks label a map only when some blob of it could be mostly pale (gather._could_keep): a ball in
    range moving with a pale rim is not (pendulum4 labelled its moving map twice a frame per camera to keep nothing,
    0.8-0.9 ms of a 9 ms step); a pale streak, or a faint one, still is, and still kept."""
    from stereotrack.evidence import gather

    labelled = []
    kept = gather._kept_streaks

    def counted(*args, **kwargs):
        labelled.append(1)
        return kept(*args, **kwargs)

    monkeypatch.setattr(gather, "_kept_streaks", counted)
    rim_blue = cv2.cvtColor(np.uint8([[[118, 200, 170]]]), cv2.COLOR_HSV2BGR)[0, 0].tolist()

    def ball_with_rim(img):
        cv2.circle(img, (300, 240), 16, PALE_BLUE, -1)
        cv2.circle(img, (300, 240), 14, rim_blue, -1)

    _, ball = _moving_view(ball_with_rim)
    assert ball.moving[240, 300] == 1 and not labelled
    _, streak = _moving_view(lambda img: cv2.line(img, (200, 240), (236, 246), PALE_BLUE, 6))
    assert streak.moving[243, 218] == 1 and labelled
    labelled.clear()
    assert _faint_view(0.09).moving.sum() > 0 and labelled


def test_a_row_pair_is_passed_over_only_when_none_of_its_words_holds_a_seed():
    """streak_candidates passes over a pair of rows at once when no word of either holds a pixel of the map out of the
    range (and out of the faint pass's ``before``): a blob mostly pale whose only pale pixels lie in the second row of a
    pair, the last two words of a width that is a whole number of words, is still found (as labelling finds it)."""
    from stereotrack.evidence.gather import _could_keep, _nearest

    for w in (64, 72):
        h = 40
        mask, in_range = np.zeros((h, w), np.uint8), np.zeros((h, w), np.uint8)
        mask[16, w - 12 : w - 4 : 2] = in_range[16, w - 12 : w - 4 : 2] = 1  # the cells' corners, in range
        mask[17, w - 12 : w - 4] = 1  # under them, pale: 8 of the blob's 12 pixels
        assert _could_keep(mask, in_range, 6, None) is True
        assert _candidates_by_labelling(mask, np.zeros(0, np.uint8), in_range, None, None, 6, 0)
        cells = np.full(((h + 1) // 2, (w + 1) // 2), 2, np.uint8)
        marks = (cells, _nearest(cells.shape[0], h), _nearest(cells.shape[1], w))
        before = np.zeros((h, w), np.uint8)
        before[17, w - 6 : w - 4] = 1
        expected = _candidates_by_labelling(mask, np.zeros(0, np.uint8), in_range, before, marks, 6, 0)
        assert _could_keep(mask, in_range, 6, None, before, marks, 0) == expected


# A far fast ball's pale cells (fast_ball tune seed 35, frame 52, camera 0: 0 none, 2 changed since the frame before), as
# rows and columns from the streak's corner: 11 cells, 44 pixels, filling 0.79 of its moments' ellipse.
RAGGED = [(0, 1), (0, 2), (0, 5)] + [(1, c) for c in range(8)]


def _faint_cells_kept(cells_at) -> list:
    """gather._kept_streaks on the pale pixels of these cells of the background's grid (changed since the frame before),
    with nothing in range or moving around them."""
    from stereotrack.evidence import gather

    h, w = 480, 640
    cells = np.zeros((h // 2, w // 2), np.uint8)
    pale = np.zeros((h, w), np.uint8)
    for r, c in cells_at:
        cells[120 + r, 100 + c] = 2
        pale[2 * (120 + r) : 2 * (121 + r), 2 * (100 + c) : 2 * (101 + c)] = 1
    marks = (cells, gather._nearest(h // 2, h), gather._nearest(w // 2, w))
    none = np.zeros((h, w), np.uint8)
    return gather._kept_streaks(pale, none, 6, None, none, marks, 24)


def test_a_faint_streaks_ragged_cells_are_a_streak_and_a_square_of_them_is_not():
    """A faint streak's pale pixels are the background grid's 2 x 2 cells: a ragged capsule that fills less of its
    ellipse than a mask's streak (0.7-0.8, where a mask's must fill 0.8) and steps in width by a cell. Asked as much
    as a mask's, the streaks of fast_ball tune seed 35 were no streak in 15 of 148 views of its balls. A square of
    cells is no streak."""
    kept = _faint_cells_kept(RAGGED)
    assert len(kept) == 1 and len(kept[0][0]) == 4 * len(RAGGED)
    assert _faint_cells_kept([(r, c) for r in range(4) for c in range(4)]) == []


def test_a_faint_streak_kept_by_its_ragged_cells_is_a_streak_in_the_blobs_read_later():
    """The blob finder judges the kept pixels again, by a mask's streak test: without being told, it takes them for a disc
    of half their length (the particles' ball half as deep, no streak for explain-away to triangulate). Told, the blob is
    a streak as wide as its cells, and a blob its pixels joined is not made one."""
    from stereotrack.evidence.blobs import find_blobs
    from stereotrack.evidence.gather import _as_streaks

    kept = _faint_cells_kept(RAGGED)
    pale = np.zeros((480, 640), np.uint8)
    pale[kept[0]] = 1
    blobs = find_blobs(pale, "components", 6)
    assert len(blobs) == 1 and not blobs.swept[0] and blobs.ball_radii()[0] > 6  # half its length
    told = _as_streaks(blobs, kept)
    assert told.swept[0] and told.ball_radii()[0] < 2.5
    shifted = [(kept[0][0] + 1, kept[0][1] + 1)]  # its first pixel off the label grid's (every second pixel's)
    moved = np.zeros_like(pale)
    moved[shifted[0]] = 1
    assert _as_streaks(find_blobs(moved, "components", 6), shifted).swept[0]
    cv2.circle(pale, (int(blobs.centres[0, 0]), int(blobs.centres[0, 1]) + 6), 6, 1, -1)  # a disc joined to it
    joined = find_blobs(pale, "components", 6)
    assert len(joined) == 1 and not _as_streaks(joined, kept).swept[0]
