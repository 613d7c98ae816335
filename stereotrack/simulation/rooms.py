"""Random rooms for stress scenes: walls, floor, ceiling, windows, doors, posters and furniture, drawn from a seed.

Every colour is checked against the target's hue: the room itself never
shows the ball's colour (a saturated colour is at least ``HUE_CLEARANCE``
away in hue, or it is nearly grey), so whatever target-coloured thing a
stress category adds is the only one.
"""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np

from .shapes import Box, Cylinder, Decal, Ellipsoid, Material, Wall, rotation

HUE_CLEARANCE = 22  # OpenCV hue steps (0..179) between the room's saturated colours and the target's hue
GREY_SATURATION = 45  # colours below this saturation may take any hue


def hsv_to_bgr(h: float, s: float, v: float) -> tuple[float, float, float]:
    px = np.uint8([[[int(round(h)) % 180, int(np.clip(s, 0, 255)), int(np.clip(v, 0, 255))]]])
    return tuple(float(c) for c in cv2.cvtColor(px, cv2.COLOR_HSV2BGR)[0, 0])


def bgr_to_hsv(bgr) -> tuple[int, int, int]:
    px = np.uint8([[list(np.clip(np.round(bgr), 0, 255))]])
    return tuple(int(c) for c in cv2.cvtColor(px, cv2.COLOR_BGR2HSV)[0, 0])


def hue_distance(a: float, b: float) -> float:
    d = abs(a - b) % 180
    return min(d, 180 - d)


def safe_colour(
    rng: np.random.Generator, avoid_hue: float | None, sat: tuple[float, float], val: tuple[float, float], avoid_white: bool = False
) -> tuple[float, float, float]:
    """A colour whose hue keeps clear of the target's (unless it is nearly grey)."""
    for _ in range(100):
        h, s, v = rng.uniform(0, 180), rng.uniform(*sat), rng.uniform(*val)
        if avoid_white and s < 40 and v > 150:
            continue
        if avoid_hue is None or s < GREY_SATURATION or hue_distance(h, avoid_hue) >= HUE_CLEARANCE:
            return hsv_to_bgr(h, s, v)
    return hsv_to_bgr(0, 0, float(np.mean(val)))


@dataclass(frozen=True)
class Room:
    walls: tuple[Wall, ...]
    props: tuple
    floor_z: float
    ceiling_z: float
    back_y: float
    left_x: float
    right_x: float


def _poster(rng, centre, size, avoid_hue) -> list[Decal]:
    """A poster or picture: a paper rectangle with a few coloured blocks, discs and a frame on it."""
    out = [Decal("rect", centre, (size[0] + 0.04, size[1] + 0.04), safe_colour(rng, avoid_hue, (0, 60), (20, 90)))]  # frame
    out.append(Decal("rect", centre, size, safe_colour(rng, avoid_hue, (0, 30), (200, 245))))
    for _ in range(int(rng.integers(2, 7))):
        c = (centre[0] + rng.uniform(-0.4, 0.4) * size[0], centre[1] + rng.uniform(-0.4, 0.4) * size[1])
        s = (rng.uniform(0.1, 0.5) * size[0], rng.uniform(0.1, 0.5) * size[1])
        kind = "ellipse" if rng.uniform() < 0.4 else "rect"
        out.append(Decal(kind, c, s, safe_colour(rng, avoid_hue, (30, 220), (40, 230))))
    return out


def make_room(
    rng: np.random.Generator,
    avoid_hue: float | None,
    width: float,
    depth: float,
    camera_height: float,
    ceiling: float,
    white: bool = False,
    hall: bool = False,
) -> Room:
    """A closed room around the cameras (at the origin, looking along +y): floor, ceiling, back and side walls."""
    left = -width * rng.uniform(0.35, 0.65)
    right = left + width
    floor, top = -camera_height, ceiling - camera_height
    front = -1.0
    if white:
        paint = hsv_to_bgr(rng.uniform(0, 180), rng.uniform(0, 14), rng.uniform(215, 250))
    else:
        paint = safe_colour(rng, avoid_hue, (0, 35) if rng.uniform() < 0.7 else (20, 80), (150, 240))
    seeds = rng.integers(0, 2**31, 8)
    floor_kind = str(rng.choice(["wood", "tiles", "carpet"]))
    if floor_kind == "wood" and not hall:  # wood looks like wood, unless that is the ball's hue: then grey laminate
        wood_ok = avoid_hue is None or hue_distance(15, avoid_hue) >= HUE_CLEARANCE + 8
        floor_colour = hsv_to_bgr(rng.uniform(8, 22), rng.uniform(60, 150) if wood_ok else rng.uniform(0, 35), rng.uniform(80, 190))
    else:
        floor_colour = safe_colour(rng, avoid_hue, (0, 60) if not hall else (0, 160), (70, 190))
    ceil_colour = hsv_to_bgr(0, 0, rng.uniform(200, 245))

    def wall_decals(length: float, on_back: bool) -> list[Decal]:
        out: list[Decal] = [Decal("rect", (length / 2, 0.05), (length, 0.1), safe_colour(rng, avoid_hue, (0, 40), (150, 240)))]  # skirting
        u = rng.uniform(0.3, length - 0.3)
        if rng.uniform() < 0.5:  # a window: bright sky, a frame, a cross bar
            wsz = (rng.uniform(0.8, 1.6), rng.uniform(0.8, 1.3))
            wc = (u, rng.uniform(1.2, 1.7))
            out += [
                Decal("rect", wc, (wsz[0] + 0.1, wsz[1] + 0.1), hsv_to_bgr(0, 0, rng.uniform(200, 240))),
                Decal("rect", wc, wsz, hsv_to_bgr(rng.uniform(95, 110), rng.uniform(10, 60), rng.uniform(235, 255))),
                Decal("rect", wc, (0.04, wsz[1]), hsv_to_bgr(0, 0, 230)),
            ]
        u = rng.uniform(0.5, length - 0.5)
        if rng.uniform() < 0.4:  # a door
            out += [
                Decal("rect", (u, 1.02), (0.9, 2.04), safe_colour(rng, avoid_hue, (0, 110), (60, 230))),
                Decal("ellipse", (u + 0.33, 1.0), (0.05, 0.05), hsv_to_bgr(0, 0, 180)),
            ]
        for _ in range(int(rng.integers(0, 4 if not hall else 7))):
            size = (rng.uniform(0.3, 1.0), rng.uniform(0.3, 0.9))
            out += _poster(rng, (rng.uniform(0.4, length - 0.4), rng.uniform(1.0, 2.0)), size, avoid_hue)
        for _ in range(int(rng.integers(0, 3))):  # sockets, switches
            out.append(Decal("rect", (rng.uniform(0.2, length - 0.2), rng.choice([0.3, 1.05])), (0.08, 0.08), hsv_to_bgr(0, 0, 235)))
        return out

    h = top - floor
    walls = [
        Wall(
            (left, depth, floor),
            (1, 0, 0),
            (0, 0, 1),
            (right - left, h),
            paint,
            "paint",
            0.05,
            tuple(wall_decals(right - left, True)),
            int(seeds[0]),
        ),
        Wall(
            (left, front, floor),
            (0, 1, 0),
            (0, 0, 1),
            (depth - front, h),
            paint,
            "paint",
            0.05,
            tuple(wall_decals(depth - front, False)),
            int(seeds[1]),
        ),
        Wall(
            (right, front, floor),
            (0, 1, 0),
            (0, 0, 1),
            (depth - front, h),
            paint,
            "paint",
            0.05,
            tuple(wall_decals(depth - front, False)),
            int(seeds[2]),
        ),
        Wall((left, front, floor), (1, 0, 0), (0, 1, 0), (right - left, depth - front), floor_colour, floor_kind, 0.08, (), int(seeds[3])),
        Wall((left, front, top), (1, 0, 0), (0, 1, 0), (right - left, depth - front), ceil_colour, "paint", 0.04, (), int(seeds[4])),
    ]
    props = furniture(rng, avoid_hue, left, right, depth, floor, white)
    return Room(tuple(walls), tuple(props), floor, top, depth, left, right)


def furniture(rng, avoid_hue, left, right, back, floor, white=False) -> list:
    """Cabinets, shelves with books, a table, a bin, a lamp: against the back and side walls."""
    out = []

    def mat(sat=(0, 90), val=(50, 220), specular=0.05):
        return Material(safe_colour(rng, avoid_hue, sat, val, avoid_white=False), specular, 12.0)

    x = left + rng.uniform(0.1, 0.6)
    while x < right - 0.5:  # along the back wall
        kind = rng.choice(["cabinet", "shelf", "table", "gap", "plant", "bin"], p=[0.2, 0.2, 0.2, 0.2, 0.1, 0.1])
        w = float(rng.uniform(0.4, 1.4))
        if x + w > right - 0.05:
            break
        cx = x + w / 2
        if kind == "cabinet":
            hgt = rng.uniform(0.7, 1.9)
            d = rng.uniform(0.35, 0.6)
            out.append(Box((cx, back - d / 2, floor + hgt / 2), (w, d, hgt), mat()))
        elif kind == "shelf":
            hgt, d = rng.uniform(1.2, 2.0), 0.3
            m = mat()
            for z in np.arange(0.02, hgt, rng.uniform(0.3, 0.45)):
                out.append(Box((cx, back - d / 2, floor + z), (w, d, 0.025), m))
                books_x = x + 0.03
                while books_x < x + w - 0.06 and z + 0.3 < hgt:  # a row of books
                    bw = rng.uniform(0.02, 0.06)
                    bh = rng.uniform(0.15, 0.27)
                    if rng.uniform() < 0.8:
                        out.append(
                            Box((books_x + bw / 2, back - d / 2, floor + z + 0.0125 + bh / 2), (bw, 0.2, bh), mat((20, 200), (40, 220)))
                        )
                    books_x += bw + 0.003
            for sx in (x, x + w):
                out.append(Box((sx, back - d / 2, floor + hgt / 2), (0.02, d, hgt), m))
        elif kind == "table":
            hgt, d = rng.uniform(0.7, 0.78), rng.uniform(0.5, 0.8)
            m = mat()
            y = back - d / 2 - rng.uniform(0.0, 0.5)
            out.append(Box((cx, y, floor + hgt - 0.02), (w, d, 0.04), m))
            for lx in (x + 0.04, x + w - 0.04):
                for ly in (y - d / 2 + 0.04, y + d / 2 - 0.04):
                    out.append(Box((lx, ly, floor + (hgt - 0.04) / 2), (0.04, 0.04, hgt - 0.04), m))
            for _ in range(int(rng.integers(0, 3))):  # things on the table: a box, a cup
                s = rng.uniform(0.06, 0.2)
                if rng.uniform() < 0.5:
                    out.append(
                        Box(
                            (cx + rng.uniform(-0.3, 0.3) * w, y, floor + hgt + s / 2),
                            (s, s * 0.8, s),
                            mat((0, 200)),
                            rotation(rng.uniform(0, 90)),
                        )
                    )
                else:
                    out.append(Cylinder((cx + rng.uniform(-0.3, 0.3) * w, y, floor + hgt + 0.05), 0.04, 0.1, mat((0, 200), specular=0.2)))
        elif kind == "plant":
            r = rng.uniform(0.12, 0.2)
            out.append(Cylinder((cx, back - 0.3, floor + 0.15), r, 0.3, mat((0, 120))))
            leaves = Material(safe_colour(rng, avoid_hue, (90, 200), (40, 130)), 0.1, 8.0)
            for _ in range(5):
                off = rng.uniform(-1, 1, 3) * [0.15, 0.15, 0.15]
                out.append(
                    Ellipsoid(
                        (cx + off[0], back - 0.3 + off[1], floor + 0.55 + off[2]),
                        tuple(rng.uniform(0.08, 0.18, 3)),
                        leaves,
                        rotation(rng.uniform(0, 180), rng.uniform(-30, 30)),
                    )
                )
        elif kind == "bin":
            out.append(Cylinder((cx, back - 0.25, floor + 0.2), 0.15, 0.4, mat((0, 150))))
        x += w + rng.uniform(0.05, 0.4)
    for side in (left, right):  # a tall cabinet or a radiator on each side wall, sometimes
        if rng.uniform() < 0.5:
            d = rng.uniform(0.35, 0.55)
            length = rng.uniform(0.6, 1.5)
            y = rng.uniform(1.5, max(1.6, back - length))
            hgt = rng.uniform(0.5, 2.0)
            inward = 1 if side == left else -1
            out.append(Box((side + inward * d / 2, y, floor + hgt / 2), (d, length, hgt), mat()))
    return out
