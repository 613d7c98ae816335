"""What the network sink sends (formats.md section 5): one message per frame, as JSON or as an OSC bundle.

A message holds the frame, its capture time, the send time, and every track
tracks.csv would write for that frame (``FrameResult.confirmed``): id,
target, state, position, velocity, standard deviations, and for a ball in
free flight where its parabola comes down through the landing height.
"""

from __future__ import annotations

import json
import math
from collections.abc import Sequence
from typing import NamedTuple

import numpy as np

from ..errors import StereotrackError
from ..results import TrackEstimate
from ..tracks.flight import landing

SCHEMA = "stereotrack.tracks"
VERSION = 1
OSC_PREFIX = "/stereotrack"
NAN = float("nan")


class FrameTracks(NamedTuple):
    """The part of a frame's result that is sent."""

    frame: int
    timestamps: tuple[float, ...]  # the cameras' capture times, seconds
    tracks: tuple[TrackEstimate, ...]  # the reported tracks (tracks.csv's rows of this frame)

    @property
    def time(self) -> float:
        """The pair's capture time, as tracks.csv writes it (FramePair.time)."""
        return sum(self.timestamps) / len(self.timestamps)  # = np.mean for a few cameras, without its per-call cost


def _r(values: np.ndarray | list[float], digits: int) -> list[float | None]:
    """Rounded numbers; a non-finite one becomes null (JSON has no NaN)."""
    values = values.tolist() if isinstance(values, np.ndarray) else values
    return [round(v, digits) if math.isfinite(v) else None for v in values]


def message(frame: FrameTracks, sent: float, landing_height: float | None) -> dict:
    """The frame as a JSON-ready dict (schema version 1). ``sent``: the send time on the capture clock;
    ``landing_height``: metres along the up axis, or None for no landing predictions.
    Plain floats throughout: numpy's per-call cost would dominate on 3-vectors."""
    tracks = []
    time = frame.time
    for tr in frame.tracks:
        sd = [math.sqrt(v) if v > 0 else 0.0 for v in tr.covariance.diagonal().tolist()]
        land = None
        if tr.flight is not None and landing_height is not None:
            hit = landing(tr.flight, landing_height, after=time)
            if hit is not None:
                land = {"position": _r(hit[0], 5), "time": round(hit[1], 6)}
        tracks.append(
            {
                "id": int(tr.track_id),
                "target": tr.target,
                "state": tr.state,
                "position": _r(tr.position, 5),
                "velocity": _r(tr.velocity, 4),
                "sd": _r(sd, 5),
                "flying": tr.flight is not None,
                "landing": land,
            }
        )
    return {
        "schema": SCHEMA,
        "version": VERSION,
        "frame": int(frame.frame),
        "time": round(time, 6),
        "sent": round(sent, 6),
        "landing_height": landing_height,
        "tracks": tracks,
    }


def encode_json(msg: dict) -> bytes:
    return json.dumps(msg, separators=(",", ":"), allow_nan=False).encode()


def osc_encoder():
    """``encode(msg) -> bytes``: the message as one OSC bundle (python-osc, an optional extra, imported here only)."""
    try:
        from pythonosc.osc_bundle_builder import IMMEDIATELY, OscBundleBuilder
        from pythonosc.osc_message_builder import OscMessageBuilder
    except ImportError:
        raise StereotrackError(
            "--osc needs python-osc: pip install 'stereotrack[osc]' (or pip install python-osc) in this environment"
        ) from None

    def osc(address: str, args: Sequence[tuple[object, str]]):
        b = OscMessageBuilder(address=f"{OSC_PREFIX}/{address}")
        for value, kind in args:
            b.add_arg(value, kind)
        return b.build()

    def encode(msg: dict) -> bytes:
        bundle = OscBundleBuilder(IMMEDIATELY)
        head = [(msg["version"], "i"), (msg["frame"], "i"), (msg["time"], "d"), (msg["sent"], "d"), (len(msg["tracks"]), "i")]
        bundle.add_content(osc("frame", head))
        for t in msg["tracks"]:
            numbers = [(NAN if v is None else v, "f") for v in (*t["position"], *t["velocity"], *t["sd"])]  # OSC floats know NaN
            bundle.add_content(osc("track", [(t["id"], "i"), (t["target"], "s"), (t["state"], "s"), *numbers]))
            if t["landing"] is not None:
                land = t["landing"]
                bundle.add_content(osc("landing", [(t["id"], "i"), *[(v, "f") for v in land["position"]], (land["time"], "d")]))
        return bundle.build().dgram

    return encode
