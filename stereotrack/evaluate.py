"""Tracks against ground truth: CLEAR MOT (via py-motmetrics) plus 3D error statistics.

A track matches a true ball when they are closer than the gate (0.1 m by
default). motmetrics' distance helper returns *squared* distances, so this
module passes plain Euclidean distances to the accumulator: MOTP is then in
metres and is reported in millimetres.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass

import numpy as np

from .errors import StereotrackError


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

    def as_dict(self) -> dict:
        return asdict(self)

    def table(self) -> str:
        rows = [
            ("MOTA", f"{self.mota:.3f}"),
            ("MOTP", f"{self.motp_mm:.1f} mm"),
            ("recall", f"{self.recall:.3f}"),
            ("precision", f"{self.precision:.3f}"),
            ("id switches", str(self.id_switches)),
            ("misses", str(self.misses)),
            ("false positives", str(self.false_positives)),
            ("mean 3D error", f"{self.mean_error_mm:.1f} mm"),
            ("p95 3D error", f"{self.p95_error_mm:.1f} mm"),
            ("frames / true ball-frames", f"{self.frames} / {self.truth_objects}"),
            ("gate", f"{self.gate_m:g} m"),
        ]
        return "\n".join(f"{k:>26}: {v}" for k, v in rows)


def evaluate(tracks: np.ndarray, truth: np.ndarray, gate: float = 0.1, frames: np.ndarray | None = None) -> Evaluation:
    """tracks: M x 6 (frame, time, id, x, y, z); truth: K x 5 (frame, id, x, y, z)."""
    try:
        import motmetrics as mm
    except ImportError:  # pragma: no cover - depends on the install
        raise StereotrackError("evaluation needs py-motmetrics: pip install 'stereotrack[eval]'") from None
    if gate <= 0:
        raise StereotrackError(f"--gate must be positive metres, got {gate}")
    if frames is None:
        frames = np.union1d(truth[:, 0], tracks[:, 0]).astype(int)
    acc = mm.MOTAccumulator(auto_id=False)
    t_by_frame = _group(truth, 0)
    h_by_frame = _group(tracks, 0)
    for f in frames:
        t = t_by_frame.get(int(f), np.zeros((0, 5)))
        h = h_by_frame.get(int(f), np.zeros((0, 6)))
        d = np.linalg.norm(t[:, None, 2:5] - h[None, :, 3:6], axis=2) if len(t) and len(h) else np.zeros((len(t), len(h)))
        d = np.where(d <= gate, d, np.nan)
        acc.update(t[:, 1].astype(int).tolist(), h[:, 2].astype(int).tolist(), d, frameid=int(f))
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

    return Evaluation(
        frames=int(len(frames)),
        truth_objects=int(val("num_objects")),
        matches=int(val("num_matches")),
        misses=int(val("num_misses")),
        false_positives=int(val("num_false_positives")),
        id_switches=int(val("num_switches")),
        mota=val("mota"),
        motp_mm=1e3 * val("motp"),
        recall=val("recall"),
        precision=val("precision"),
        mean_error_mm=1e3 * float(err.mean()) if len(err) else float("nan"),
        p95_error_mm=1e3 * float(np.percentile(err, 95)) if len(err) else float("nan"),
        gate_m=gate,
    )


def _group(rows: np.ndarray, col: int) -> dict[int, np.ndarray]:
    if len(rows) == 0:
        return {}
    order = np.argsort(rows[:, col], kind="stable")
    rows = rows[order]
    keys, starts = np.unique(rows[:, col].astype(int), return_index=True)
    return {int(k): part for k, part in zip(keys, np.split(rows, starts[1:]))}
