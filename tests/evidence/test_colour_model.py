import cv2
import numpy as np
import pytest

from stereotrack.config import Target
from stereotrack.errors import StereotrackError
from stereotrack.evidence.colour import target_mask, to_hsv
from stereotrack.evidence.colour_model import ColourModel, load_colour_model, separation

# A user's range for a pink ball: hue 140-175 from saturation 60. The room has a wall of a duller magenta
# that the range also takes in; the ball is a brighter, more saturated pink.
PINK = Target("pink", (140, 60, 50), (175, 255, 255))
WALL_HSV = (148, 110, 170)
BALL_HSV = (166, 230, 220)


def room(rng: np.random.Generator, ball_at=(400, 240), radius=18) -> np.ndarray:
    """BGR 640x480: grey floor, a magenta wall over the left half, a pink ball, sensor noise."""
    hsv = np.zeros((480, 640, 3), np.uint8)
    hsv[:] = (0, 0, 120)
    hsv[:, :320] = WALL_HSV
    cv2.circle(hsv, ball_at, radius, BALL_HSV, -1)
    bgr = cv2.cvtColor(hsv, cv2.COLOR_HSV2BGR).astype(np.int16)
    return np.clip(bgr + rng.normal(0, 3, bgr.shape).round(), 0, 255).astype(np.uint8)


def probability_at(model: ColourModel, hsv: np.ndarray, ys, xs) -> float:
    return float(model.probability(hsv)[ys, xs].mean()) / 255.0


def test_a_wall_in_the_range_counts_less_than_the_ball_and_learning_sharpens_it():
    rng = np.random.default_rng(3)
    img = room(rng)
    hsv = to_hsv(img)
    in_range = target_mask(hsv, PINK)
    assert in_range[240, 100] and in_range[240, 400]  # the range alone cannot tell them apart
    model = ColourModel.for_target(PINK)
    wall = probability_at(model, hsv, slice(100, 380), slice(50, 300))
    ball = probability_at(model, hsv, slice(235, 245), slice(395, 405))
    assert wall < 0.2 and ball > 0.6  # the wall's colour covers a quarter of the room; the ball's hardly any
    for _ in range(20):  # the ball tracked: its colours learnt under its disc
        frame = to_hsv(room(rng))
        model.learn(frame, target_mask(frame, PINK), np.array([[400.0, 240.0]]), np.array([18.0]))
    assert probability_at(model, hsv, slice(235, 245), slice(395, 405)) > 0.95
    assert probability_at(model, hsv, slice(100, 380), slice(50, 300)) < wall / 2
    disc = np.zeros(in_range.shape, np.uint8)
    cv2.circle(disc, (400, 240), 18, 1, -1)
    assert separation(model.probability(hsv), disc, in_range) > 0.9


def test_the_same_colour_on_the_ball_and_on_the_wall_is_not_sharpened_away():
    """When the wall is the ball's exact colour the model cannot help; it must not make the ball vanish either."""
    hsv = np.zeros((480, 640, 3), np.uint8)
    hsv[:] = (0, 0, 120)
    hsv[:, :320] = BALL_HSV
    model = ColourModel.for_target(PINK)
    model.learn(hsv, target_mask(hsv, PINK), np.array([[400.0, 240.0]]), np.array([18.0]))
    p = model.probability(hsv)
    assert 0.0 < p[240, 100] / 255.0 < 0.7  # uncertain, not zero: shape and motion decide


def write_model(tmp_path, **changes):
    model = ColourModel.for_target(PINK)
    path = tmp_path / "pink.colour.yaml"
    model.save(path, PINK, 0.8)
    return model, path


def test_a_saved_model_reads_back(tmp_path):
    model, path = write_model(tmp_path)
    assert np.allclose(load_colour_model(path) / load_colour_model(path).sum(), model.ball, atol=1e-5)


@pytest.mark.parametrize(
    "damage, message",
    [
        ("missing", "colour model file not found"),
        ("truncated", "truncated|not a readable|not a stereotrack"),
        ("version", "version 99"),
        ("bytes", "not a readable|not a stereotrack"),
        ("other yaml", "not a stereotrack colour model"),
    ],
)
def test_a_damaged_model_file_is_one_clear_error(tmp_path, damage, message):
    _, path = write_model(tmp_path)
    text = path.read_text()
    if damage == "missing":
        path.unlink()
    elif damage == "truncated":
        path.write_text(text[: len(text) // 2])
    elif damage == "version":
        path.write_text(text.replace("version: 1", "version: 99"))
    elif damage == "bytes":
        path.write_bytes(np.random.default_rng(0).integers(0, 256, 3000, dtype=np.uint8).tobytes())
    else:
        path.write_text("targets: []\n")
    with pytest.raises(StereotrackError, match=message):
        load_colour_model(path)


def test_a_white_ball_learnt_against_a_white_wall_leaves_no_speckle_on_the_wall():
    """A white ball's hue and saturation are a white wall's: learnt from the tracked ball, the ball's histogram
    comes close to the wall's. With equal odds p hovered about 0.5 on the wall and the mask (p > 0.5) was
    speckle over it; a ball of every hue needs its colour WHITE_ODDS times likelier on the ball."""
    white = Target("white", (0, 0, 150), (179, 50, 255))
    rng = np.random.default_rng(5)

    def frame():
        hsv = np.zeros((480, 640, 3), np.uint8)
        hsv[:] = (100, 12, 220)  # a white wall, faintly blue
        cv2.circle(hsv, (400, 240), 18, (100, 14, 235), -1)  # the white ball, a little brighter
        bgr = cv2.cvtColor(hsv, cv2.COLOR_HSV2BGR).astype(np.int16)
        return to_hsv(np.clip(bgr + rng.normal(0, 3, bgr.shape).round(), 0, 255).astype(np.uint8))

    model = ColourModel.for_target(white)
    for _ in range(30):
        hsv = frame()
        model.learn(hsv, target_mask(hsv, white), np.array([[400.0, 240.0]]), np.array([18.0]))
    hsv = frame()
    in_range = target_mask(hsv, white)
    wall = (model.probability(hsv) > 127) & (in_range > 0)
    wall[200:280, 360:440] = False
    assert in_range[100:380, 50:300].all()  # the range takes the whole wall
    assert wall.mean() < 0.01  # hardly a speck of it is kept
    assert ColourModel.for_target(PINK).odds == 1.0  # a ball of one hue keeps even odds


def test_a_white_ball_s_model_keeps_even_odds_until_it_has_learnt():
    """Before any track taught it, the ball's histogram is the range's box: a still white ball in a colour rarer
    in the room than that box's share is found by its colour alone, so the odds grow only with what was learnt."""
    white = Target("white", (0, 0, 150), (179, 50, 255))
    hsv = np.zeros((480, 640, 3), np.uint8)
    hsv[:] = (100, 4, 220)  # a white wall
    hsv[200:224, 300:326] = (60, 30, 230)  # a faintly green-white ball, 1/500 of the image: rarer than the box's 1/270 per bin
    model = ColourModel.for_target(white)
    assert model.probability(hsv)[212, 312] > 127


def test_a_white_thing_near_the_white_balls_colour_is_the_rooms_not_the_balls():
    """A white ball's colour is never rare in a white room: a door, a shelf of white books or a lamp of a white
    close to the ball's fills a few per cent of the view, and noise spreads both over the same hue-saturation bins.
    With the ball's colour three times likelier on the ball, 40 % of such a door was kept (a false ball that
    never moves: white_ball tune seeds 15 and 17, a white book and a shelf tracked for the whole scene); a colour
    must be WHITE_ODDS times likelier on the ball, and the ball itself is still kept."""
    white = Target("white", (0, 0, 150), (179, 50, 255))
    rng = np.random.default_rng(7)

    def frame():
        hsv = np.zeros((480, 640, 3), np.uint8)
        hsv[:] = (100, 6, 200)  # a white wall, faintly blue
        hsv[100:250, 420:520] = (28, 24, 228)  # a cream-white door, 5 % of the view
        cv2.circle(hsv, (200, 300), 18, (20, 30, 235), -1)  # the ball, a warmer white
        bgr = cv2.cvtColor(hsv, cv2.COLOR_HSV2BGR).astype(np.int16)
        return to_hsv(np.clip(bgr + rng.normal(0, 2, bgr.shape).round(), 0, 255).astype(np.uint8))

    model = ColourModel.for_target(white)
    for _ in range(60):  # two seconds of a tracked ball
        hsv = frame()
        model.learn(hsv, target_mask(hsv, white), np.array([[200.0, 300.0]]), np.array([18.0]))
    p = model.probability(frame())
    assert (p[110:240, 430:510] > 127).mean() < 0.2  # little of the door is kept
    assert (p[290:310, 190:210] > 127).mean() > 0.8  # the ball is


def _held_ball(skin=(8, 110, 120), ball=(17, 210, 215)):
    """A ball in a hand, or on a prop, of the orange range's hue: the frame (HSV), the range and its mask."""
    orange = Target("orange", (4, 88, 75), (26, 255, 255))
    hsv = np.zeros((480, 640, 3), np.uint8)
    hsv[:] = (100, 60, 150)  # a blue-grey wall, out of the range
    cv2.rectangle(hsv, (210, 150), (260, 240), skin, -1)  # a hand: 1.5 per cent of the view (a wall's over WALL)
    cv2.circle(hsv, (260, 150), 18, ball, -1)  # the ball in the hand, at the skin's corner
    return hsv, orange, target_mask(hsv, orange)


def test_a_hand_under_a_held_ball_is_not_taught_as_the_ball():
    """A ball held in a hand (or a track that stayed on the hand it was thrown from) has skin in its core. Skin
    of the range's hue, on things of the room that move (arms, hands), stays the room's colour; the ball's stays
    the ball's."""
    hsv, orange, in_range = _held_ball()
    moving = np.zeros((240, 320), np.uint8)  # motion.py's grid
    moving[75:120, 105:125] = 1  # the hand moves (its lower part, off the ball)
    model = ColourModel.for_target(orange)
    for _ in range(30):
        model.learn(hsv, in_range, np.array([[250.0, 165.0]]), np.array([18.0]), moving)  # the track half in the hand
    p = model.probability(hsv) / 255.0
    assert p[200, 230] < 0.5  # skin: out of the mask (taught, 0.74; the first frame, before it moved, taught some)
    assert p[145, 265] > 0.9  # the ball


def test_a_still_prop_under_a_ball_is_taught_as_the_ball():
    """A prop of the ball's own colour that never moves (a box the ball rests on) is no hand: its colour is the
    ball's, and refusing it kept the ball from learning its colour (static_props tune seed 49: 0.944 -> -0.289)."""
    hsv, orange, in_range = _held_ball(skin=(17, 210, 215))  # the "hand" is of the ball's colour, and still
    model = ColourModel.for_target(orange)
    for _ in range(30):
        model.learn(hsv, in_range, np.array([[250.0, 165.0]]), np.array([18.0]), np.zeros((240, 320), np.uint8))
    assert (model.probability(hsv) / 255.0)[145, 265] > 0.5  # the ball's colour stays the ball's


def test_a_white_ball_learns_its_colour_where_the_room_holds_it_too():
    """A white ball's colour is the room's by nature: every colour of its core is taught (WHITE_ODDS weighs it)."""
    white = Target("white", (0, 0, 150), (179, 50, 255))
    assert ColourModel.for_target(white).spread == 0.0 and ColourModel.for_target(PINK).spread > 0.0


def test_a_ball_before_a_wall_of_its_own_colour_learns_its_colour():
    """The room may hold the ball's colour far more than the tracked cores do where a wall of the ball's hue is
    (hue_wall tune seed 20: a curtain, 19 per cent of the view): a colour over more than WALL of the view is a
    wall's, not a thing's like skin, and is taught (refused, the ball's histogram stayed the range's box)."""
    hsv = np.zeros((480, 640, 3), np.uint8)
    hsv[:] = (0, 0, 120)  # a grey room
    hsv[:, :200] = BALL_HSV  # a curtain of the ball's very colour
    cv2.circle(hsv, (400, 240), 18, BALL_HSV, -1)
    model = ColourModel.for_target(PINK)
    for _ in range(30):
        model.learn(hsv, target_mask(hsv, PINK), np.array([[400.0, 240.0]]), np.array([18.0]))
    assert model.probability(hsv)[240, 400] / 255.0 > 0.5  # (refused: 0.04)


def test_the_colours_of_moving_things_of_the_room_are_things_not_a_still_props_or_a_walls():
    """``things`` (what evidence_maps takes a hand's colour for): the colours of which more than MOVED of the
    room's pixels move, off the tracked balls' discs (a ball's rim and blur are its own); not a static prop's of
    the ball's colour (static_props tune seed 28), not a wall's (WALL), even where something of it moves, not a
    colour rarer than THING."""
    orange = Target("orange", (4, 88, 75), (26, 255, 255))
    skin, ball, prop = (8, 110, 120), (17, 210, 215), (22, 160, 200)
    hsv = np.zeros((480, 640, 3), np.uint8)
    hsv[:] = (100, 60, 150)  # a blue-grey wall, out of the range
    hsv[:, :160] = (12, 180, 200)  # a wall of the range's hue: a quarter of the view
    cv2.rectangle(hsv, (200, 300), (250, 390), skin, -1)  # a hand: 1.5 per cent of the view
    cv2.rectangle(hsv, (500, 350), (600, 470), prop, -1)  # a still prop
    cv2.circle(hsv, (400, 150), 18, ball, -1)
    hsv[40:48, 400:408] = blend = (24, 120, 180)  # a rare colour, a ball's blend with the room
    foreground = np.zeros((240, 320), np.uint8)  # the background's grid: half the image's
    foreground[150:195, 100:125] = 1  # the hand moves
    cv2.circle(foreground, (200, 75), 12, 1, -1)  # the ball and its blur
    foreground[100:120, 40:60] = 1  # something before the wall of the range's hue
    foreground[20:24, 200:204] = 1  # the blend moves
    model = ColourModel.for_target(orange)
    for _ in range(10):
        model.table(hsv)
        model.learn(hsv, target_mask(hsv, orange), np.array([[400.0, 150.0]]), np.array([18.0]), foreground)
    things = model.moving_things()
    bin_of = lambda c: (c[0] // 4, c[1] // 8)  # noqa: E731
    assert things[bin_of(skin)] == 1
    assert things[bin_of(prop)] == 0 and things[bin_of(ball)] == 0 and things[bin_of((12, 180))] == 0
    assert things[bin_of(blend)] == 0  # rarer than THING
    table, once = model.table_and_things(hsv)  # what the tracker reads every frame: the same two, found once
    assert np.array_equal(once, things) and np.array_equal(table, model.table(hsv))
    white = ColourModel.for_target(Target("white", (0, 0, 150), (179, 50, 255)))
    white.learn(hsv, np.ones(hsv.shape[:2], np.uint8), foreground=foreground)
    assert white.moving_things() is None  # a white ball: none


# An orange ball held in a cupped hand (the fingers over the bottom of its core), the juggler's other hand empty and
# moving, a face: skin is in the orange range (hue 12, saturation 80-95 of a range from 73), spread thin over two bins.
ORANGE = Target("orange", (0, 73, 60), (20, 255, 255))
SKIN_HSV = ((12, 80, 190), (12, 90, 200))  # two hue-saturation bins, in 4-pixel stripes (as the model samples)
ORANGE_HSV = (5, 220, 210)
HELD, EMPTY, FACE = (200, 240), (440, 240), (320, 100)


def juggler() -> tuple[np.ndarray, np.ndarray]:
    """HSV 640x480 (a dull blue wall out of range) and the foreground (1: the empty hand moves)."""
    hsv = np.zeros((480, 640, 3), np.uint8)
    hsv[:] = (100, 30, 150)
    skin = np.zeros((480, 640), bool)
    skin[HELD[1] + 1 : HELD[1] + 20, HELD[0] - 16 : HELD[0] + 16] = True  # the holding hand below the ball's centre ...
    cv2.circle(hsv, HELD, 12, ORANGE_HSV, -1)
    skin[EMPTY[1] - 12 : EMPTY[1] + 12, EMPTY[0] - 12 : EMPTY[0] + 12] = True
    skin[FACE[1] - 15 : FACE[1] + 15, FACE[0] - 15 : FACE[0] + 15] = True
    ys, xs = np.nonzero(skin)
    hsv[ys, xs] = np.where(((xs // 4) % 2 == 0)[:, None], SKIN_HSV[0], SKIN_HSV[1])  # ... over its core's rim: fingers
    foreground = np.zeros((480, 640), np.uint8)
    foreground[EMPTY[1] - 14 : EMPTY[1] + 14, EMPTY[0] - 14 : EMPTY[0] + 14] = 1
    return hsv, foreground


def test_an_empty_hand_is_no_ball_once_its_skin_was_refused_as_the_holding_hands():
    hsv, foreground = juggler()
    in_range = target_mask(hsv, ORANGE)
    assert in_range[EMPTY[1], EMPTY[0]] and in_range[HELD[1], HELD[0]]  # skin passes the range
    model = ColourModel.for_target(ORANGE)
    for frame in range(17):  # the held ball is tracked from the fourth frame: its core (fingers and all) teaches
        model.table(hsv)
        model.learn(hsv, in_range, np.array([HELD], float)[: int(frame >= 3)], np.array([12.0])[: int(frame >= 3)], foreground)
    prob = model.probability(hsv)
    hand = prob[EMPTY[1] - 12 : EMPTY[1] + 12, EMPTY[0] - 12 : EMPTY[0] + 12]
    assert (hand > 127).mean() < 0.1  # the empty hand is the room's (on main, the range's box kept all of it: 1.0)
    assert prob[HELD[1] - 6, HELD[0]] > 200  # the ball's own colour keeps its p


def test_a_moving_colour_the_cores_never_showed_keeps_the_first_histograms_doubt():
    """A fast ball's blur is a blend the cores do not show; it moves off the tracks' discs as a hand does (motion_blur)."""
    hsv, foreground = juggler()
    hsv[EMPTY[1] - 12 : EMPTY[1] + 12, EMPTY[0] - 12 : EMPTY[0] + 12] = (12, 120, 190)  # a colour the held ball's core lacks
    in_range = target_mask(hsv, ORANGE)
    model = ColourModel.for_target(ORANGE)
    for frame in range(17):
        model.table(hsv)
        model.learn(hsv, in_range, np.array([HELD], float)[: int(frame >= 3)], np.array([12.0])[: int(frame >= 3)], foreground)
    assert model.moving_things()[12 // 4, 120 // 8]  # a moving thing's colour ...
    assert model.probability(hsv)[EMPTY[1], EMPTY[0]] > 127  # ... never refused, so not withdrawn


@pytest.mark.parametrize("half, lit", [(0, 1), (12, 5)])
def test_a_moving_balls_own_colour_is_never_withdrawn(half, lit):
    """The tracked ball's highlight is a colour a still prop of the room shares (so SPREAD does not teach it) and that
    moves off the track's disc too. A glint of it alone (half 0: the ball's shading past the disc, no main colour
    moving): fewer of its moving pixels lie off the discs than on the core; a ball not yet tracked (half 12 px, five
    samples of the highlight against the core's three): more, but fewer than of the balls' main colour. Neither is a
    hand's: the highlight keeps the range box's doubt."""
    highlight = (16, 200, 230)  # in the orange range, another bin than the ball's body (ORANGE_HSV)
    hsv = np.zeros((480, 640, 3), np.uint8)
    hsv[:] = (100, 30, 150)
    cv2.circle(hsv, HELD, 12, ORANGE_HSV, -1)
    hsv[HELD[1], HELD[0] : HELD[0] + 12 : 4] = highlight  # three of the core's samples (every 4th pixel is sampled)
    hsv[100:124, 500:524] = highlight  # the still prop: 36 samples, over ten times the core's
    hsv[EMPTY[1] - half : EMPTY[1] + half, EMPTY[0] - half : EMPTY[0] + half] = ORANGE_HSV  # the untracked ball, moving ...
    start = EMPTY[0] - 4 * (lit // 2)
    hsv[EMPTY[1], start : start + 4 * lit : 4] = highlight  # ... with ``lit`` samples of the highlight
    foreground = np.zeros((480, 640), np.uint8)
    foreground[EMPTY[1] - half - 4 : EMPTY[1] + half + 4, EMPTY[0] - half - 4 : EMPTY[0] + half + 4] = 1
    in_range = target_mask(hsv, ORANGE)
    model = ColourModel.for_target(ORANGE)
    for frame in range(17):
        model.table(hsv)
        model.learn(hsv, in_range, np.array([HELD], float)[: int(frame >= 3)], np.array([12.0])[: int(frame >= 3)], foreground)
    assert model.moving_things()[16 // 4, 200 // 8]  # a moving thing's colour, refused as the ball's (SPREAD) ...
    assert model.ball[16 // 4, 200 // 8] < model.first[16 // 4, 200 // 8]
    assert model.probability(hsv)[HELD[1], HELD[0]] > 127  # ... but the ball's own: it keeps its p (withdrawn: 0)


def test_skin_over_a_walls_share_of_the_view_is_a_things_while_it_moves_as_things_do(monkeypatch):
    """A juggler near the camera: one skin colour (face, arms, hands) over WALL of the view, and a wall's share alone
    took it for a wall's and taught it from the held ball's core (hands tune seed 110: a quarter of the ball's histogram,
    and the face and arms were balls). It moves as things do (THING_MOVES: skin 0.28-0.30 of its pixels; a wall of the
    ball's hue 0.01-0.09, what passes before it), so it is refused as a small hand's is; that wall is still taught."""
    import stereotrack.evidence.colour_model as colour_model

    hsv, orange, in_range = _held_ball()
    cv2.rectangle(hsv, (30, 20), (180, 150), (8, 110, 120), -1)  # a face and arms of the hand's skin: 8 per cent in all
    moving = np.zeros((240, 320), np.uint8)  # motion.py's grid
    moving[75:120, 105:125] = 1  # the hand moves (its lower part, off the ball) ...
    moving[50:75, 15:90] = 1  # ... and the arms: a third of the skin in all

    def taught():
        model = ColourModel.for_target(orange)
        for _ in range(30):
            model.learn(hsv, in_range, np.array([[250.0, 165.0]]), np.array([18.0]), moving)  # the track half in the hand
        return model.probability(hsv) / 255.0

    p = taught()
    assert p[200, 230] < 0.5 and p[60, 100] < 0.5  # the hand and the face: out of the mask
    assert p[145, 265] > 0.9  # the ball
    monkeypatch.setattr(colour_model, "THING_MOVES", 1e9)  # a wall's share of the view alone makes a wall's colour
    assert taught()[60, 100] > 0.5


def test_a_wall_of_the_balls_colour_that_something_passes_before_is_still_taught():
    """THING_MOVES: a wall of the ball's hue over a fifth of the view, a twentieth of it moving (someone walks before it)."""
    hsv = np.zeros((480, 640, 3), np.uint8)
    hsv[:] = (0, 0, 120)
    hsv[:, :200] = BALL_HSV
    cv2.circle(hsv, (400, 240), 18, BALL_HSV, -1)
    moving = np.zeros((240, 320), np.uint8)
    moving[100:140, 20:60] = 1  # 1600 of the wall's 24000 cells on this grid
    model = ColourModel.for_target(PINK)
    for _ in range(30):
        model.learn(hsv, target_mask(hsv, PINK), np.array([[400.0, 240.0]]), np.array([18.0]), moving)
    assert model.probability(hsv)[240, 400] / 255.0 > 0.5


def test_a_holding_hands_skin_is_not_taught_as_the_ball_though_the_room_holds_too_little_of_it_to_refuse():
    """HOLDER: a ball held deep in the hand (the fingers over its core from above its centre), the other hand empty and
    moving, no face: the room holds too little of the skin for SPREAD to refuse it, and it was taught until the empty
    hand was a ball (hands tune seed 59: skin a third of the ball's histogram). The holding hand goes on round the
    ball, its skin as dense in a ring around the ball as on its core: a holder's colour, not the ball's."""
    hsv = np.zeros((480, 640, 3), np.uint8)
    hsv[:] = (100, 30, 150)
    skin = np.zeros((480, 640), bool)
    skin[HELD[1] - 5 : HELD[1] + 20, HELD[0] - 16 : HELD[0] + 16] = True  # the holding hand, over the core's lower half
    cv2.circle(hsv, HELD, 12, ORANGE_HSV, -1)
    skin[EMPTY[1] - 12 : EMPTY[1] + 12, EMPTY[0] - 12 : EMPTY[0] + 12] = True
    ys, xs = np.nonzero(skin)
    hsv[ys, xs] = np.where(((xs // 4) % 2 == 0)[:, None], SKIN_HSV[0], SKIN_HSV[1])
    foreground = np.zeros((480, 640), np.uint8)
    foreground[EMPTY[1] - 14 : EMPTY[1] + 14, EMPTY[0] - 14 : EMPTY[0] + 14] = 1  # the empty hand moves
    in_range = target_mask(hsv, ORANGE)
    model = ColourModel.for_target(ORANGE)
    for frame in range(40):  # the held ball is tracked from the fourth frame
        model.table(hsv)
        model.learn(hsv, in_range, np.array([HELD], float)[: int(frame >= 3)], np.array([12.0])[: int(frame >= 3)], foreground)
    prob = model.probability(hsv)
    assert (prob[EMPTY[1] - 12 : EMPTY[1] + 12, EMPTY[0] - 12 : EMPTY[0] + 12] > 127).mean() < 0.1  # taught: all of it
    assert model.ball[SKIN_HSV[0][0] // 4, SKIN_HSV[0][1] // 8] < 0.01  # taught: 0.39 of the ball's histogram
    assert prob[HELD[1] - 8, HELD[0]] > 200  # the ball's own colour keeps its p
