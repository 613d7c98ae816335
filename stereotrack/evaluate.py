"""Tracks against ground truth: CLEAR MOT (via py-motmetrics) plus 3D error statistics.

A track matches a true ball when they are closer than the gate (0.1 m by
default). motmetrics' distance helper returns *squared* distances, so this
module passes plain Euclidean distances to the accumulator: MOTP is then in
metres and is reported in millimetres.

A ball that fewer than two cameras see (truth's optional ``clear`` column,
the cameras that show a quarter of it or more, else ``visible``, the cameras
that show some of it; both written by the simulator) has no 3D evidence: it
may be tracked but need not be. Such a row is neither a miss when no track
is near it nor a match, and a track that stands on it is not a false positive
(MOTChallenge's handling of ignored ground truth: assign first, then drop
both).
"""

from __future__ import annotations

from dataclasses import asdict, dataclass

import numpy as np

from .errors import StereotrackError

NO_BALL = "n/a (no ball seen by two cameras)"


def figure(value: float, fmt: str, missing: str = "n/a", unit: str = "") -> str:
    """A score's figure as text: ``missing`` where it is undefined (NaN: nothing to score it against)."""
    return missing if value != value else f"{value:{fmt}}{unit}"


@dataclass(frozen=True)
class Evaluation:
    frames: int
    truth_objects: int  # true ball-frames
    matches: int
    misses: int
    false_positives: int
    id_switches: int
    mota: float
    motp_mm: float
    recall: float
    precision: float
    mean_error_mm: float
    p95_error_mm: float
    gate_m: float
    optional_objects: int = 0  # ball-frames left out: fewer than MIN_VIEWS cameras see them (truth's clear or visible)

    def as_dict(self) -> dict:
        return asdict(self)

    def table(self) -> str:
        rows = [
            ("MOTA", figure(self.mota, ".3f", NO_BALL)),
            ("MOTP", figure(self.motp_mm, ".1f", "n/a", " mm")),
            ("recall", figure(self.recall, ".3f", NO_BALL)),
            ("precision", figure(self.precision, ".3f")),
            ("id switches", str(self.id_switches)),
            ("misses", str(self.misses)),
            ("false positives", str(self.false_positives)),
            ("mean 3D error", figure(self.mean_error_mm, ".1f", "n/a", " mm")),
            ("p95 3D error", figure(self.p95_error_mm, ".1f", "n/a", " mm")),
            ("frames / true ball-frames", f"{self.frames} / {self.truth_objects}"),
            ("optional ball-frames", f"{self.optional_objects} (seen by fewer than {MIN_VIEWS} cameras: not scored)"),
            ("gate", f"{self.gate_m:g} m"),
        ]
        return "\n".join(f"{k:>26}: {v}" for k, v in rows)


MIN_VIEWS = 2  # triangulation needs two views: a ball fewer cameras see is optional


def evaluate(
    tracks: np.ndarray, truth: np.ndarray, gate: float = 0.1, frames: np.ndarray | None = None, views: np.ndarray | None = None
) -> Evaluation:
    """tracks: M x 6 (frame, time, id, x, y, z); truth: K x 5 (frame, id, x, y, z).

    ``views``: K cameras that see some of each true ball (None: every ball is required).
    """
    acc, frames = _accumulated(tracks, truth, gate, frames, views)
    import motmetrics as mm  # (there: _accumulated said what to install when it is missing)

    mh = mm.metrics.create()
    s = mh.compute(
        acc,
        metrics=[
            "num_frames",
            "num_objects",
            "num_matches",
            "num_misses",
            "num_false_positives",
            "num_switches",
            "mota",
            "motp",
            "recall",
            "precision",
        ],
        name="run",
    )
    ev = acc.mot_events
    err = ev.loc[ev["Type"].isin(["MATCH", "SWITCH"]), "D"].to_numpy(dtype=float)
    err = err[np.isfinite(err)]

    def val(k):
        v = float(s[k].iloc[0])
        return v if np.isfinite(v) else 0.0

    truth_objects, matches, false_positives = int(val("num_objects")), int(val("num_matches")), int(val("num_false_positives"))
    return Evaluation(
        frames=int(len(frames)),
        truth_objects=truth_objects,
        matches=matches,
        misses=int(val("num_misses")),
        false_positives=false_positives,
        id_switches=int(val("num_switches")),
        mota=val("mota") if truth_objects else float("nan"),  # 0 / 0: no ball two cameras see, no tracker's failure
        # ... and no match, no MOTP (it read 0.0 mm: perfect); no track where one counts, no precision
        motp_mm=1e3 * val("motp") if matches else float("nan"),
        recall=val("recall") if truth_objects else float("nan"),
        precision=val("precision") if matches + false_positives else float("nan"),
        mean_error_mm=1e3 * float(err.mean()) if len(err) else float("nan"),
        p95_error_mm=1e3 * float(np.percentile(err, 95)) if len(err) else float("nan"),
        gate_m=gate,
        optional_objects=int((_optional(truth, views) & np.isin(truth[:, 0], frames)).sum()),
    )


MATCH, SWITCH, MISS, FALSE = 0, 1, 2, 3  # error_events' kinds


def error_events(
    tracks: np.ndarray, truth: np.ndarray, gate: float = 0.1, frames: np.ndarray | None = None, views: np.ndarray | None = None
) -> np.ndarray:
    """What ``evaluate`` counts, event by event: E x 4 int (frame, kind, true ball's id, track's id), kind one of
    MATCH, SWITCH, MISS, FALSE (a miss has no track: -1; a false positive no ball: -1). For telling where a run's
    errors are (benchmarks/error_classes.py)."""
    ev = _accumulated(tracks, truth, gate, frames, views)[0].mot_events
    kinds = {"MATCH": MATCH, "SWITCH": SWITCH, "MISS": MISS, "FP": FALSE}
    ev = ev[ev["Type"].isin(list(kinds))]
    out = np.full((len(ev), 4), -1, np.int64)
    out[:, 0] = ev.index.get_level_values("FrameId").to_numpy()
    out[:, 1] = ev["Type"].map(kinds).to_numpy()
    for col, name in ((2, "OId"), (3, "HId")):
        ids = ev[name].to_numpy(dtype=float)
        out[:, col] = np.where(np.isfinite(ids), np.nan_to_num(ids), -1)
    return out


def _accumulated(tracks: np.ndarray, truth: np.ndarray, gate: float, frames, views: np.ndarray | None):
    """The py-motmetrics accumulator of ``tracks`` against ``truth`` over ``frames`` (``evaluate``'s arguments), and
    the frames (None: every frame either names)."""
    try:
        import motmetrics as mm
    except ImportError:  # pragma: no cover - depends on the install
        raise StereotrackError("evaluation needs py-motmetrics: pip install 'stereotrack[eval]'") from None
    if gate <= 0:
        raise StereotrackError(f"--gate must be positive metres, got {gate}")
    if frames is None:
        frames = np.union1d(truth[:, 0], tracks[:, 0]).astype(int)
    acc = mm.MOTAccumulator(auto_id=False)
    optional = _optional(truth, views)
    t_by_frame = _group(np.column_stack([truth[:, :5], optional]), 0)
    h_by_frame = _group(tracks, 0)
    for f in frames:
        t = t_by_frame.get(int(f), np.zeros((0, 6)))
        h = h_by_frame.get(int(f), np.zeros((0, 6)))
        d = np.linalg.norm(t[:, None, 2:5] - h[None, :, 3:6], axis=2) if len(t) and len(h) else np.zeros((len(t), len(h)))
        d = np.where(d <= gate, d, np.nan)
        if t[:, 5].any():
            t, h, d = _without_optional(t, h, d)
        acc.update(t[:, 1].astype(int).tolist(), h[:, 2].astype(int).tolist(), d, frameid=int(f))
    return acc, frames


def _optional(truth: np.ndarray, views: np.ndarray | None) -> np.ndarray:
    """Per truth row: is its ball optional (fewer than MIN_VIEWS cameras see it; none without ``views``)?"""
    return np.zeros(len(truth), bool) if views is None else np.asarray(views) < MIN_VIEWS


def _without_optional(t: np.ndarray, h: np.ndarray, d: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """A frame's truth, tracks and gated distances without its optional balls and the tracks assigned to them."""
    from scipy.optimize import linear_sum_assignment

    keep_h = np.ones(len(h), bool)
    if len(h):
        rows, cols = linear_sum_assignment(np.where(np.isnan(d), 1e9, d))
        hit = np.isfinite(d[rows, cols]) & (t[rows, 5] > 0)
        keep_h[cols[hit]] = False
    keep_t = t[:, 5] == 0
    return t[keep_t], h[keep_h], d[np.ix_(keep_t, keep_h)]


def _group(rows: np.ndarray, col: int) -> dict[int, np.ndarray]:
    if len(rows) == 0:
        return {}
    order = np.argsort(rows[:, col], kind="stable")
    rows = rows[order]
    keys, starts = np.unique(rows[:, col].astype(int), return_index=True)
    return {int(k): part for k, part in zip(keys, np.split(rows, starts[1:]))}
