"""What the network sink sends (formats.md section 5): one message per frame, as JSON or as an OSC bundle.

A message holds the frame, its capture time, the send time, and every track
tracks.csv would write for that frame (``FrameResult.confirmed``): id,
target, state, position, velocity, standard deviations, and for a ball in
free flight where its parabola comes down through the landing height.

Encoding runs on the tracker's thread for every frame, so it works on plain
floats and writes the JSON text directly (numbers formatted as tracks.csv
formats them): five times cheaper than numpy calls on 3-vectors plus
``json.dumps`` of a dict, measured in BENCHMARKS.md.
"""

from __future__ import annotations

import json
import math
from collections.abc import Callable
from functools import lru_cache
from typing import NamedTuple

from ..errors import StereotrackError
from ..results import TrackEstimate
from ..tracks.flight import landing

SCHEMA = "stereotrack.tracks"
VERSION = 1
OSC_PREFIX = "/stereotrack"


class FrameTracks(NamedTuple):
    """The part of a frame's result that is sent."""

    frame: int
    timestamps: tuple[float, ...]  # the cameras' capture times, seconds
    tracks: tuple[TrackEstimate, ...]  # the reported tracks (tracks.csv's rows of this frame)

    @property
    def time(self) -> float:
        """The pair's capture time, as tracks.csv writes it (FramePair.time)."""
        return sum(self.timestamps) / len(self.timestamps)  # = np.mean for a few cameras, without its per-call cost


class TrackFields(NamedTuple):
    """One track as sent: plain Python values."""

    id: int
    target: str
    state: str
    position: list[float]  # metres
    velocity: list[float]  # metres per second
    sd: list[float]  # metres
    flying: bool
    landing: tuple[list[float], float] | None  # (point in metres, time in seconds)


class Message(NamedTuple):
    frame: int
    time: float
    sent: float
    landing_height: float | None
    tracks: list[TrackFields]


def message(frame: FrameTracks, sent: float, landing_height: float | None) -> Message:
    """The frame's message (schema version 1). ``sent``: the send time on the capture clock;
    ``landing_height``: metres along the up axis, or None for no landing points."""
    time = frame.time
    tracks = []
    for tr in frame.tracks:
        land = None
        if tr.flight is not None and landing_height is not None:
            hit = landing(tr.flight, landing_height, after=time)
            if hit is not None:
                land = (hit[0].tolist(), hit[1])
        sd = [math.sqrt(v) if v > 0 else 0.0 for v in tr.covariance.diagonal().tolist()]
        tracks.append(
            TrackFields(int(tr.track_id), tr.target, tr.state, tr.position.tolist(), tr.velocity.tolist(), sd, tr.flight is not None, land)
        )
    return Message(int(frame.frame), time, sent, landing_height, tracks)


def _num(v: float, digits: int) -> str:
    """A JSON number with ``digits`` decimals (as tracks.csv writes it); null when not finite (JSON has no NaN)."""
    return f"{v:.{digits}f}" if math.isfinite(v) else "null"


def _nums(values: list[float], digits: int) -> str:
    return "[" + ",".join([_num(v, digits) for v in values]) + "]"


@lru_cache(maxsize=256)
def _text(s: str) -> str:
    return json.dumps(s)


def encode_json(msg: Message) -> bytes:
    """The message as one compact JSON object (formats.md section 5)."""
    tracks = []
    for t in msg.tracks:
        land = "null" if t.landing is None else f'{{"position":{_nums(t.landing[0], 5)},"time":{_num(t.landing[1], 6)}}}'
        tracks.append(
            f'{{"id":{t.id},"target":{_text(t.target)},"state":{_text(t.state)},"position":{_nums(t.position, 5)},'
            f'"velocity":{_nums(t.velocity, 4)},"sd":{_nums(t.sd, 5)},"flying":{"true" if t.flying else "false"},"landing":{land}}}'
        )
    height = "null" if msg.landing_height is None else repr(float(msg.landing_height))
    return (
        f'{{"schema":"{SCHEMA}","version":{VERSION},"frame":{msg.frame},"time":{_num(msg.time, 6)},"sent":{_num(msg.sent, 6)},'
        f'"landing_height":{height},"tracks":[{",".join(tracks)}]}}'
    ).encode()


def osc_encoder() -> Callable[[Message], bytes]:
    """``encode(msg) -> bytes``: the message as one OSC bundle (python-osc, an optional extra, imported here only)."""
    try:
        from pythonosc.osc_bundle_builder import IMMEDIATELY, OscBundleBuilder
        from pythonosc.osc_message_builder import OscMessageBuilder
    except ImportError:
        raise StereotrackError(
            "--osc needs python-osc: pip install 'stereotrack[osc]' (or pip install python-osc) in this environment"
        ) from None

    def osc(address: str, *args: tuple[object, str]):
        b = OscMessageBuilder(address=f"{OSC_PREFIX}/{address}")
        for value, kind in args:
            b.add_arg(value, kind)
        return b.build()

    def encode(msg: Message) -> bytes:
        bundle = OscBundleBuilder(IMMEDIATELY)
        bundle.add_content(osc("frame", (VERSION, "i"), (msg.frame, "i"), (msg.time, "d"), (msg.sent, "d"), (len(msg.tracks), "i")))
        for t in msg.tracks:
            numbers = [(v, "f") for v in (*t.position, *t.velocity, *t.sd)]  # OSC floats carry NaN as it is
            bundle.add_content(osc("track", (t.id, "i"), (t.target, "s"), (t.state, "s"), *numbers))
            if t.landing is not None:
                bundle.add_content(osc("landing", (t.id, "i"), *[(v, "f") for v in t.landing[0]], (t.landing[1], "d")))
        return bundle.build().dgram

    return encode
