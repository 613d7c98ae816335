"""Stress scenes: one random scene per (category, seed), in the situations real rooms produce.

``stress_scene(category, seed)`` draws everything from
``numpy.random.default_rng([crc32(category), seed])``: the rig, the room,
the balls' colour, size, number and paths, and the category's own trouble
(how many posters, where the props stand, the juggling pattern, how the
light drifts ...), so no two seeds share a layout and no seed can be tuned
to. The target each scene asks the tracker for is what a user would type
for the ball (``typed_target``), never a range fitted to the render.
"""

from __future__ import annotations

import argparse
import dataclasses
import zlib
from collections.abc import Callable

import numpy as np

from ..config import TrackerSettings
from .hands import Hand, Juggled, JugglePattern
from .placing import (
    GAMMA,
    Placer,
    assemble,
    ball_colour,
    base_rig,
    one_view_point,
    place_balls,
    room_for,
    room_lighting,
    target_material,
    typed_target,
)  # fmt: skip
from .rooms import bgr_to_hsv, hsv_to_bgr, safe_colour
from .shapes import TAG_SKIN, TAG_TARGET_COLOURED, Box, Cylinder, Decal, Ellipsoid, Material, rotation
from .spec import BallSpec, CameraResponse, SceneSpec
from .trajectories import Flight, drag_per_metre

SEED_BASE = {"tune": 0, "report": 1_000_000}  # report seeds start a million away from tune seeds: the sets never overlap


def seeds(which: str, n: int) -> list[int]:
    """The first ``n`` seeds of the 'tune' or the 'report' set."""
    if n > 1_000_000:
        raise ValueError("at most a million seeds per set")
    return [SEED_BASE[which] + i for i in range(n)]


# --------------------------------------------------------------------------- the categories


def hue_wall(seed: int, rng) -> SceneSpec:
    """Walls, posters and curtains of the ball's hue behind the balls."""
    sc = Placer(rng, base_rig(rng), 30.0, 90)
    colour = ball_colour(rng)
    hue = bgr_to_hsv(colour)[0]
    radius = float(rng.uniform(0.03, 0.045))
    balls = place_balls(sc, colour, radius, int(rng.integers(1, 5)))
    room = room_for(sc, hue)
    decals = []
    length = room.right_x - room.left_x
    view_half = (room.back_y + 0.0) * np.tan(np.radians(sc.rig.hfov / 2))  # what the cameras see of the back wall
    for _ in range(int(rng.integers(1, 5))):
        kind = rng.choice(["paint", "poster", "curtain", "stripes"], p=[0.3, 0.3, 0.25, 0.15])
        c = hsv_to_bgr(hue + rng.uniform(-7, 7), rng.uniform(100, 235), rng.uniform(150, 250))
        u = float(np.clip(-room.left_x + rng.uniform(-1, 1) * view_half, 0.3, length - 0.3))
        if kind == "paint":  # a painted section of wall, floor to ceiling or up to a height
            w = rng.uniform(0.8, 3.0)
            top = rng.uniform(1.5, room.ceiling_z - room.floor_z)
            decals.append(Decal("rect", (u, top / 2), (w, top), c, tag=TAG_TARGET_COLOURED))
        elif kind == "poster":
            w, h = rng.uniform(0.4, 1.2), rng.uniform(0.5, 1.2)
            decals.append(Decal("rect", (u, rng.uniform(1.0, 1.8)), (w, h), c, angle=float(rng.uniform(-3, 3)), tag=TAG_TARGET_COLOURED))
        elif kind == "curtain":
            w = rng.uniform(0.8, 2.0)
            top = room.ceiling_z - room.floor_z - 0.1
            decals.append(Decal("curtain", (u, top / 2 + 0.05), (w, top), c, tag=TAG_TARGET_COLOURED))
        else:  # stripes: wallpaper, a banner
            for k in range(int(rng.integers(2, 6))):
                decals.append(
                    Decal("rect", (u + k * 0.25, rng.uniform(1.0, 1.6)), (0.1, rng.uniform(0.6, 1.6)), c, tag=TAG_TARGET_COLOURED)
                )
    target = typed_target(colour, radius, rng)
    return assemble("hue_wall", seed, sc, balls, room, target, extra_decals={0: decals})


def static_props(seed: int, rng) -> SceneSpec:
    """Static things of the ball's colour: boxes, cans, cushions, big balls, shapes on the wall, and ball-sized ones only one camera sees."""
    sc = Placer(rng, base_rig(rng), 30.0, 90)
    colour = ball_colour(rng)
    hue = bgr_to_hsv(colour)[0]
    radius = float(rng.uniform(0.03, 0.045))
    room = room_for(sc, hue)
    props, decals = [], []
    stand = Material(safe_colour(rng, hue, (0, 40), (40, 200)), 0.2, 20.0)
    for _ in range(int(rng.integers(3, 9))):
        kind = rng.choice(["box", "can", "cushion", "big ball", "wall shape"], p=[0.3, 0.2, 0.2, 0.1, 0.2])
        mat = target_material(rng, hue)
        if kind == "wall shape":
            n = int(rng.integers(3, 11))
            ang = np.sort(rng.uniform(0, 2 * np.pi, n)) if n > 5 else np.linspace(0, 2 * np.pi, n, endpoint=False)
            rad = rng.uniform(0.5, 1.0, n) if rng.uniform() < 0.5 else np.where(np.arange(n) % 2 == 0, 1.0, 0.45)
            pts = tuple((float(np.cos(a) * r), float(np.sin(a) * r)) for a, r in zip(ang, rad))
            size = rng.uniform(0.1, 0.6)
            u = float(np.clip(-room.left_x + rng.uniform(-1, 1) * room.back_y * 0.5, 0.4, room.right_x - room.left_x - 0.4))
            decals.append(
                Decal("polygon", (u, rng.uniform(0.5, 2.0)), (size, size), mat.colour, float(rng.uniform(0, 360)), pts, TAG_TARGET_COLOURED)
            )
            continue
        p = sc.point((0.9, max(1.0, room.back_y - 0.4)))
        on_floor = rng.uniform() < 0.4
        if kind == "box":
            size = tuple(rng.uniform(0.05, 0.5, 3))
            shape = Box(tuple(p), size, mat, rotation(rng.uniform(0, 90), rng.uniform(-10, 10) if not on_floor else 0))
            half_h = size[2] / 2
        elif kind == "can":
            r, hgt = rng.uniform(0.03, 0.2), rng.uniform(0.08, 0.6)
            shape = Cylinder(tuple(p), float(r), float(hgt), mat, rotation(0, rng.uniform(-15, 15) if not on_floor else 0))
            half_h = hgt / 2
        elif kind == "cushion":  # clearly not a sphere: one axis half the others at most, or all large
            a = rng.uniform(0.06, 0.3)
            axes = (a, a * rng.uniform(0.6, 1.2), a * rng.uniform(0.25, 0.5))
            shape = Ellipsoid(tuple(p), axes, mat, rotation(rng.uniform(0, 180), rng.uniform(-30, 30)))
            half_h = axes[2]
        else:  # a big ball (a gym ball, a balloon, a lamp globe): at least 2.5 times the ball
            r = radius * rng.uniform(2.5, 6.0)
            shape = Ellipsoid(tuple(p), (r, r, r), mat)
            half_h = r
        if on_floor:
            shape = dataclasses.replace(shape, centre=(float(p[0]), float(p[1]), room.floor_z + half_h))
        else:  # on a stand
            top = p[2] - half_h
            if top > room.floor_z + 0.05:
                props.append(Cylinder((float(p[0]), float(p[1]), (top + room.floor_z) / 2), 0.012, float(top - room.floor_z), stand))
        props.append(shape)
        sc.keep_out.append((np.asarray(shape.centre), shape.bound + 0.02))
    for _ in range(int(rng.integers(1, 3))):  # ball-sized, the ball's colour, in one camera only
        r = radius * rng.uniform(0.85, 1.2)
        p = one_view_point(sc, r, int(rng.integers(0, len(sc.cams))))
        if p is not None:
            props.append(Ellipsoid(tuple(p), (r, r, r), target_material(rng, hue)))
            sc.keep_out.append((p, r + 0.02))
    balls = place_balls(sc, colour, radius, int(rng.integers(1, 5)))
    target = typed_target(colour, radius, rng)
    return assemble("static_props", seed, sc, balls, room, target, extra_props=props, extra_decals={0: decals})


def _skin(rng) -> tuple[float, float, float]:
    return hsv_to_bgr(rng.uniform(5, 17), rng.uniform(60, 150), rng.uniform(110, 235))


def _juggler(rng, sc: Placer, hand_depth: float, hand_z: float, radius: float, skin, avoid_hue) -> tuple[JugglePattern, tuple, list]:
    """A pattern that fits the views, the two hands, and the juggler's static body (torso, head, legs)."""
    balls = int(rng.choice([1, 2, 3], p=[0.3, 0.2, 0.5]))
    beat = {1: rng.uniform(0.45, 0.8), 2: rng.uniform(0.3, 0.42), 3: rng.uniform(0.22, 0.32)}[balls]
    dwell = rng.uniform(0.35, 0.7) * 2 * beat
    dwell = min(dwell, balls * beat - 0.25)
    cx, ti = rng.uniform(0.2, 0.3), rng.uniform(0.07, 0.13)
    y, z = hand_depth, hand_z
    dy = rng.uniform(-0.05, 0.05)
    pattern = JugglePattern(
        catch=((-cx, y + dy, z), (cx, y - dy, z)),
        throw=((-ti, y, z - rng.uniform(0, 0.05)), (ti, y, z - rng.uniform(0, 0.05))),
        balls=balls,
        beat=float(beat),
        dwell=float(dwell),
        phase=float(rng.uniform(0, 3)),
    )
    skin_mat = Material(skin, 0.08, 8.0, TAG_SKIN)
    shirt = Material(safe_colour(rng, avoid_hue, (0, 200), (30, 220)), 0.03, 5.0)
    sleeve = shirt if rng.uniform() < 0.5 else None
    size = rng.uniform(0.9, 1.1)
    body_y = y + 0.34
    shoulder_z = z + 0.24
    hands = tuple(
        Hand(pattern, side, radius, (float(sx), body_y - 0.02, float(shoulder_z)), skin_mat, sleeve, float(size))
        for side, sx in ((0, -0.19), (1, 0.19))
    )
    trousers = Material(safe_colour(rng, avoid_hue, (0, 120), (20, 120)), 0.02, 5.0)
    hair = Material(hsv_to_bgr(rng.uniform(5, 25), rng.uniform(40, 160), rng.uniform(20, 120)), 0.1, 10.0)
    body = [
        Ellipsoid((0.0, body_y + 0.02, shoulder_z - 0.28), (0.19, 0.11, 0.33), shirt),
        Cylinder((0.0, body_y + 0.02, shoulder_z + 0.07), 0.05, 0.14, skin_mat),
        Ellipsoid((0.0, body_y + 0.02, shoulder_z + 0.24), (0.075, 0.09, 0.11), skin_mat),
        Ellipsoid((0.0, body_y + 0.045, shoulder_z + 0.28), (0.08, 0.085, 0.095), hair),
    ]
    floor = sc.floor_z
    hip = shoulder_z - 0.55
    if hip > floor + 0.2:
        for lx in (-0.1, 0.1):
            body.append(Ellipsoid((lx, body_y + 0.03, (hip + floor) / 2), (0.075, 0.075, (hip - floor) / 2 + 0.02), trousers))
    return pattern, hands, body


def hands(seed: int, rng) -> SceneSpec:
    """A juggler's skin-coloured hands throw, catch and hold balls of a hue near skin's: they move with the balls and hide parts of them."""
    skin = _skin(rng)
    skin_hue = bgr_to_hsv(skin)[0]
    offset = rng.uniform(3, 20) * rng.choice([-1, 1])
    colour = ball_colour(rng, (skin_hue + offset) % 180)
    hue = bgr_to_hsv(colour)[0]
    radius = float(rng.uniform(0.03, 0.04))
    for _ in range(100):
        depth = float(rng.uniform(0.9, 1.6))
        sc = Placer(rng, base_rig(rng, aim_distance=depth + rng.uniform(-0.2, 0.3)), 30.0, 90)
        room = room_for(sc, hue, back=(depth + 1.5, depth + 4.0))
        sc.floor_z = room.floor_z
        pattern, hand_movers, body = _juggler(rng, sc, depth, float(rng.uniform(-0.4, -0.15)), radius, skin, hue)
        trajs = [Juggled(pattern, i) for i in range(pattern.balls)]
        if all(sc.accept(t, radius) for t in trajs):
            break
    balls = tuple(BallSpec(t, colour=tuple(int(round(c)) for c in colour), radius=radius) for t in trajs)
    target = typed_target(colour, radius, rng)
    return assemble("hands", seed, sc, balls, room, target, extra_props=body, movers=hand_movers)


def white_ball(seed: int, rng) -> SceneSpec:
    """White or grey balls in a room with white walls; half the seeds in greyscale."""
    sc = Placer(rng, base_rig(rng), 30.0, 90)
    grey = rng.uniform() < 0.3
    colour = hsv_to_bgr(rng.uniform(0, 180), rng.uniform(0, 20), rng.uniform(140, 195) if grey else rng.uniform(215, 250))
    radius = float(rng.uniform(0.02, 0.045))
    balls = place_balls(sc, colour, radius, int(rng.integers(1, 4)))
    room = room_for(sc, None, white=True)
    mono = rng.uniform() < 0.5
    responses = tuple(CameraResponse(vignette=float(rng.uniform(0.0, 0.15)), gamma=GAMMA, greyscale=mono) for _ in range(sc.rig.cameras))
    target = typed_target(colour, radius, rng)
    return assemble("white_ball", seed, sc, balls, room, target, responses=responses)


def lighting(seed: int, rng) -> SceneSpec:
    """The room's light drifts and flickers; each camera has its own white balance, exposure, auto-exposure hunting and vignetting."""
    sc = Placer(rng, base_rig(rng), 30.0, 90)
    colour = ball_colour(rng)
    hue = bgr_to_hsv(colour)[0]
    radius = float(rng.uniform(0.03, 0.045))
    balls = place_balls(sc, colour, radius, int(rng.integers(1, 5)))
    room = room_for(sc, hue)
    n = int(rng.integers(1, 4))
    waves = tuple((float(rng.uniform(0.05, 0.35 / n)), float(rng.uniform(0.7, 6.0)), float(rng.uniform(0, 2 * np.pi))) for _ in range(n))
    responses = []
    for _ in range(sc.rig.cameras):
        exposure = rng.uniform(0.8, 1.2)
        gains = (float(exposure * rng.uniform(0.82, 1.18)), float(exposure), float(exposure * rng.uniform(0.82, 1.18)))
        hunt = ((float(rng.uniform(0.0, 0.08)), float(rng.uniform(1.0, 4.0)), float(rng.uniform(0, 2 * np.pi))),)
        responses.append(CameraResponse(gains, hunt, float(rng.uniform(0.0, 0.3)), GAMMA))
    target = typed_target(colour, radius, rng)
    return assemble(
        "lighting", seed, sc, balls, room, target, responses=tuple(responses), lighting=dataclasses.replace(room_lighting(rng), waves=waves)
    )


def motion_blur(seed: int, rng) -> SceneSpec:
    """Fast throws and swings under a long exposure: balls smeared into streaks."""
    sc = Placer(rng, base_rig(rng), 30.0, 90)
    colour = ball_colour(rng)
    hue = bgr_to_hsv(colour)[0]
    radius = float(rng.uniform(0.03, 0.045))
    balls = place_balls(
        sc,
        colour,
        radius,
        int(rng.integers(1, 4)),
        kinds=("pendulum", "throw", "line"),
        p=(0.3, 0.5, 0.2),
        speed=float(rng.uniform(1.5, 2.5)),
    )
    room = room_for(sc, hue)
    target = typed_target(colour, radius, rng)
    return assemble("motion_blur", seed, sc, balls, room, target, blur=9, exposure=float(rng.uniform(0.6, 1.0)))


def mjpg(seed: int, rng) -> SceneSpec:
    """A webcam's MJPG stream: strong JPEG compression (blocks, colour bleeding at half resolution) on a noisy sensor."""
    sc = Placer(rng, base_rig(rng), 30.0, 90)
    colour = ball_colour(rng)
    hue = bgr_to_hsv(colour)[0]
    radius = float(rng.uniform(0.025, 0.045))
    balls = place_balls(sc, colour, radius, int(rng.integers(1, 5)))
    room = room_for(sc, hue)
    target = typed_target(colour, radius, rng)
    return assemble("mjpg", seed, sc, balls, room, target, jpeg_quality=int(rng.integers(25, 66)), noise=float(rng.uniform(3, 6)))


def hd60(seed: int, rng) -> SceneSpec:
    """1280x720 at 60 frames/s with a wide lens, as HD webcams record."""
    sc = Placer(rng, base_rig(rng, width=1280, height=720, hfov=float(rng.uniform(65, 85))), 60.0, 120)
    colour = ball_colour(rng)
    hue = bgr_to_hsv(colour)[0]
    radius = float(rng.uniform(0.03, 0.045))
    balls = place_balls(sc, colour, radius, int(rng.integers(1, 5)), speed=float(rng.uniform(1.0, 1.5)))
    room = room_for(sc, hue)
    target = typed_target(colour, radius, rng)
    return assemble("hd60", seed, sc, balls, room, target, exposure=float(rng.uniform(0.3, 0.6)))


def three_cams(seed: int, rng) -> SceneSpec:
    """Three cameras in a row: a ball must be found in all three, with three views' worth of clutter."""
    sc = Placer(rng, base_rig(rng, cameras=3, baseline=float(rng.uniform(0.15, 0.35))), 30.0, 90)
    colour = ball_colour(rng)
    hue = bgr_to_hsv(colour)[0]
    radius = float(rng.uniform(0.03, 0.045))
    balls = place_balls(sc, colour, radius, int(rng.integers(1, 5)))
    room = room_for(sc, hue)
    target = typed_target(colour, radius, rng)
    return assemble("three_cams", seed, sc, balls, room, target)


# radius (m), mass (kg), drag coefficient: in flight each slows by air drag as such a ball does (a pitch at 30 m/s by
# 6-18 m/s^2), which a tracker that assumed a drag-free parabola would not survive in a real room
BALL_KINDS = {
    "baseball": (0.037, 0.145, 0.35),
    "tennis": (0.033, 0.058, 0.55),
    "handball": (0.09, 0.45, 0.47),
    "football": (0.11, 0.43, 0.25),
}


def fast_ball(seed: int, rng) -> SceneSpec:
    """Thrown or pitched balls at 10-30 m/s, 5-15 m away, slowed by air drag, crossing the view in a fraction of a second, blurred into streaks."""
    w, h = [(1280, 720), (640, 480)][int(rng.integers(0, 2))]
    rig = base_rig(
        rng,
        width=w,
        height=h,
        hfov=float(rng.uniform(45, 70)),
        baseline=float(rng.uniform(0.6, 1.6)),
        aim_distance=float(rng.uniform(8, 12)),
    )
    fps, n_frames = 60.0, 120
    sc = Placer(rng, rig, fps, n_frames)
    kind = str(rng.choice(list(BALL_KINDS)))
    radius, mass, drag_coefficient = BALL_KINDS[kind]
    drag = drag_per_metre(radius, mass, drag_coefficient)
    colour = ball_colour(rng)
    hue = bgr_to_hsv(colour)[0]
    room = room_for(sc, hue, hall=True, back=(20.0, 35.0))
    exposure = float(rng.uniform(0.4, 1.0))
    balls = []
    t0 = float(rng.uniform(0.0, 0.3))
    top_speed, nearest = 0.0, np.inf
    while t0 < n_frames / fps - 0.3:
        for _ in range(200):
            depth = rng.uniform(5, 15)
            speed = rng.uniform(10, 30)
            heading = np.radians(rng.uniform(-25, 25))
            climb = np.radians(rng.uniform(-3, 12))
            side = rng.choice([-1, 1])
            half = depth * np.tan(np.radians(rig.hfov / 2)) + rig.baseline * rig.cameras / 2 + 1.0
            start = np.array([side * half, depth - side * np.tan(heading) * half, rng.uniform(-0.6, 0.9)])
            v = speed * np.array([-side * np.cos(heading) * np.cos(climb), side * np.sin(heading) * np.cos(climb) * -1, np.sin(climb)])
            traj = Flight(tuple(start), tuple(v), t0, drag)
            pts = traj.positions(sc.times)
            seen = sc.in_view_each(pts, radius)
            if seen.sum() < 3 or not sc.clear(pts, radius):
                continue
            last = sc.times[np.flatnonzero(seen)[-1]]
            # 5-15 m away wherever a camera sees it: slanted across the view, a flight reached 20 m and more at one side
            # (a ball a pixel or two across) and came nearer than 5 m at the other
            present = (sc.times >= t0) & (sc.times <= last + 0.25)
            depths = sc.depths_seen(pts[present])
            if not depths.size or depths.min() < 5.0 or depths.max() > 15.0:
                continue
            # A ball that reaches the floor while it is still present would fly on under it, unseen but in the truth.
            if np.any(present & (pts[:, 2] < sc.floor_z + radius)):
                continue
            balls.append(
                BallSpec(traj, colour=tuple(int(round(c)) for c in colour), radius=radius, appear=t0, disappear=float(last + 0.25))
            )
            sc.paths.append(np.where((sc.times >= t0)[:, None], pts, np.nan))
            sc.radii.append(radius)
            top_speed = max(top_speed, speed)
            nearest = min(nearest, float(np.nanmin(pts[seen, 1])))
            t0 = float(last + rng.uniform(0.05, 0.4))
            break
        else:
            break
    # Enough sub-frames that the streak is smooth: one per pixel and a half of travel during the exposure.
    focal = sc.cams[0].focal_px
    blur = int(np.clip(np.ceil(focal * top_speed * exposure / fps / nearest / 1.5) + 1, 3, 48))
    target = typed_target(colour, radius, rng)
    tracker = TrackerSettings(d_min=2.0, d_max=25.0)
    return assemble("fast_ball", seed, sc, tuple(balls), room, target, tracker=tracker, blur=blur, exposure=exposure)


CATEGORIES: dict[str, Callable] = {
    f.__name__: f for f in (hue_wall, static_props, hands, white_ball, lighting, motion_blur, mjpg, hd60, three_cams, fast_ball)
}


def describe(category: str) -> str:
    return " ".join(CATEGORIES[category].__doc__.split())


def stress_scene(category: str, seed: int) -> SceneSpec:
    """The scene of ``category`` for ``seed``: always the same one, and unrelated to every other seed's."""
    rng = np.random.default_rng([zlib.crc32(category.encode()), int(seed)])
    return CATEGORIES[category](int(seed), rng)


def scene_name(text: str) -> tuple[str, int]:
    """argparse type for a stress scene named ``CATEGORY:SEED`` (the benchmarks' ``--scene``): (category, seed)."""
    category, _, seed = text.partition(":")
    if category not in CATEGORIES or not seed.isdigit():
        raise argparse.ArgumentTypeError(f"expected CATEGORY:SEED with CATEGORY one of {', '.join(CATEGORIES)}, got {text!r}")
    return category, int(seed)
