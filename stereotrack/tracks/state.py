"""One track's mutable filter state, as ``TrackManager`` keeps it between frames."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..results import Parabola
from .smoothing import FilterHistory


@dataclass(eq=False)
class TrackState:
    """One track's mutable filter state, inside ``TrackManager`` (the outside world sees TrackEstimate)."""

    track_id: int
    target: str
    x: np.ndarray  # 6: position (m), velocity (m/s)
    P: np.ndarray  # 6 x 6 covariance
    time: float  # time of x and P, seconds
    born: float  # time of the first hit
    last_hit: float  # time of the latest hit
    streak: int = 1  # hits in a row, this one included
    run: int = 1  # hits in a row up to its latest hit (``streak`` is 0 once a frame was missed)
    hits: int = 1  # hits since it was born
    confirmed: bool = False
    hit: bool = True  # matched in the latest update
    contested: bool = False  # unmatched, but an unmatched object of its colour is near: the motion model, not the detector, failed
    shadowed: bool = False  # unmatched, and where a hit track's ball is in every camera's image (``TrackManager._shadowed``)
    n_particles: int = 0
    history: list = field(default_factory=list)  # (time, position) of recent well-measured hits
    in_flight: bool = False  # gravity applies to its prediction
    parabola: Parabola | None = None  # while in flight: the parabola through its recent positions (for landing predictions)
    prediction: tuple | None = None  # (to time, from time, in_flight, x, P, F): ``predicted`` then ``update`` predict once
    launch: float | None = None  # while in flight: the height (along up, metres) its flight began at, about a hand's
    seen_at: np.ndarray | None = None  # its position after its latest hit
    caught_at: tuple | None = None  # (position, 3 x 3 covariance) at its latest hit while in flight: where a catch would hold it
    arrival: float | None = None  # m/s: its speed when it was last caught or stopped, how fast it may be launched again
    top_speed: float = 0.0  # m/s: its top speed at its hits since it was last under STOP_SPEED (0: it is slow)
    first_shown: np.ndarray | None = None  # its predicted position the first frame it was past tentative
    shown: int = 0  # frames it has been past tentative
    settled: bool = False  # see ``TrackManager._settled``
    travelled: bool = False  # see ``TrackManager._travelled``
    early: list = field(default_factory=list)  # (time, position, 3 x 3 covariance, n_particles) while tentative (position None: missed)
    entry: tuple | None = None  # (time of the frame before its first hit, its first hit as in ``early``) until judged (``_entered``)
    link: tuple | None = None  # (x, P, F): this frame's prediction from the last; None where the state was set anew
    past: FilterHistory = field(default_factory=FilterHistory)  # its frames within smooth_time, for smoothing
