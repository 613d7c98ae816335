"""Real motion capture as ball trajectories: read Qualisys TSV, link unlabelled markers into balls.

The capture (``juggling-mocap/`` in the shared real data) labels only the
robot-base markers; the balls are unnamed marker columns whose identities
swap from frame to frame, and ``0 0 0`` means "not seen". We link points
frame to frame (nearest predicted position, one-to-one assignment), bridge
short gaps by interpolation, and keep the longest tracks as the balls.
"""

from __future__ import annotations

import gzip
import io
import os
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from scipy.optimize import linear_sum_assignment

from ..errors import StereotrackError

GRAVITY = np.array([0.0, 0.0, -9.81])  # the capture's z axis points up
JUGGLING_5 = "juggling-mocap/5_ball_juggling_cut.tsv"
THROWS_6 = "juggling-mocap/6_throws_minimal_tracking_loss.tsv"


@dataclass(frozen=True, eq=False)
class MocapCapture:
    """A raw capture: every marker's position per frame, metres, NaN where not seen."""

    frequency: float  # frames per second
    times: np.ndarray  # F, seconds from the first frame
    names: tuple[str, ...]  # M marker names ("" for unnamed markers)
    points: np.ndarray  # F x M x 3, metres

    @property
    def unnamed(self) -> np.ndarray:
        """F x U x 3: the unnamed markers (the balls in the juggling captures)."""
        return self.points[:, [i for i, n in enumerate(self.names) if not n], :]


@dataclass(frozen=True, eq=False)
class BallCapture:
    """Linked ball trajectories sampled on a regular clock; NaN where a ball is not known."""

    times: np.ndarray  # F, seconds
    positions: np.ndarray  # F x B x 3, metres, capture frame (z up)

    @property
    def n_balls(self) -> int:
        return self.positions.shape[1]

    @property
    def present(self) -> np.ndarray:
        """F x B bool."""
        return np.isfinite(self.positions[..., 0])

    def speeds(self) -> np.ndarray:
        """Speeds (m/s) between consecutive samples where a ball is known at both."""
        dt = np.diff(self.times)[:, None]
        v = np.linalg.norm(np.diff(self.positions, axis=0), axis=2) / dt
        return v[np.isfinite(v)]

    def resample(self, fps: float, duration: float | None = None) -> BallCapture:
        """Linear interpolation onto t = k / fps; NaN where either neighbour is unknown."""
        end = self.times[-1] if duration is None else min(duration, self.times[-1])
        t = np.arange(0.0, end + 1e-9, 1.0 / fps)
        return BallCapture(times=t, positions=interpolate(self.times, self.positions, t))


def interpolate(times: np.ndarray, positions: np.ndarray, t: np.ndarray) -> np.ndarray:
    """Positions (F x B x 3, NaN = unknown) at times t (linear; NaN if a neighbour is unknown or t is outside)."""
    t = np.asarray(t, float)
    j = np.clip(np.searchsorted(times, t, side="right") - 1, 0, len(times) - 2)
    w = ((t - times[j]) / (times[j + 1] - times[j]))[:, None, None]
    out = (1 - w) * positions[j] + w * positions[j + 1]
    exact = np.isclose(w[:, 0, 0], 0.0)  # a sample time itself needs only that sample
    out[exact] = positions[j[exact]]
    out[(t < times[0]) | (t > times[-1])] = np.nan
    return out


def find_real_data(relative: str) -> Path:
    """Locate a motion-capture file of the real data set.

    Looked for under $STEREOTRACK_REAL_DATA, then in the package's bundled
    copy (``stereotrack/data``, gzipped), then ``../shared/data/real`` next to
    the repository (the project's shared layout).
    """
    roots = []
    if os.environ.get("STEREOTRACK_REAL_DATA"):
        roots.append(Path(os.environ["STEREOTRACK_REAL_DATA"]))
    package = Path(__file__).resolve().parents[1]  # stereotrack/
    roots += [package / "data", package.parent.parent / "shared" / "data" / "real"]
    for root in roots:
        for candidate in (root / relative, root / (relative + ".gz")):
            if candidate.is_file():
                return candidate
    raise StereotrackError(
        f"real data file {relative} not found under {', '.join(str(r) for r in roots)} (set STEREOTRACK_REAL_DATA to the folder holding it)"
    )


def read_qualisys_tsv(path: str | Path) -> MocapCapture:
    """Read a Qualisys 3D TSV export (header lines, a ``Frame Time ...`` row, one row per frame, mm)."""
    path = Path(path)
    if not path.is_file():
        raise StereotrackError(f"{path}: motion-capture file not found")
    text = gzip.decompress(path.read_bytes()).decode() if path.suffix == ".gz" else path.read_text()
    lines = text.splitlines()
    header: dict[str, list[str]] = {}
    start = None
    for i, line in enumerate(lines):
        fields = line.split("\t")
        if fields[0] == "Frame":
            start = i + 1
            break
        header[fields[0]] = fields[1:]
    if start is None or "FREQUENCY" not in header or "NO_OF_MARKERS" not in header:
        raise StereotrackError(f"{path}: not a Qualisys TSV export (no FREQUENCY/NO_OF_MARKERS header or 'Frame' row)")
    n_markers = int(header["NO_OF_MARKERS"][0])
    names = [n.strip() for n in header.get("MARKER_NAMES", [])]
    names = tuple((names + [""] * n_markers)[:n_markers])
    data = np.genfromtxt(io.StringIO("\n".join(lines[start:])), delimiter="\t", usecols=range(2 + 3 * n_markers))
    data = np.atleast_2d(data)
    if data.shape[1] != 2 + 3 * n_markers or np.isnan(data).any():
        raise StereotrackError(f"{path}: expected {2 + 3 * n_markers} numeric columns per frame row")
    points = data[:, 2:].reshape(len(data), n_markers, 3) / 1000.0
    points[np.all(points == 0.0, axis=2)] = np.nan
    freq = float(header["FREQUENCY"][0])
    return MocapCapture(frequency=freq, times=data[:, 1] - data[0, 1], names=names, points=points)


def link_points(points: np.ndarray, frequency: float, gate: float = 0.04, max_gap: int = 30) -> list[np.ndarray]:
    """Link unlabelled points (F x U x 3, NaN = empty) into tracks, each F x 3 with NaN where unseen.

    Each live track predicts its next position ballistically (velocity +
    gravity), points are assigned one-to-one to the nearest prediction within
    a gate that widens with the time unseen, and tracks unseen for more than
    ``max_gap`` frames end. Gaps inside a track are filled by linear
    interpolation.
    """
    dt = 1.0 / frequency
    n_frames = len(points)
    tracks: list[dict] = []  # {"frames": [...], "pos": [...], "v": vec, "last": frame}
    live: list[int] = []
    for f in range(n_frames):
        pts = points[f][np.isfinite(points[f, :, 0])]
        live = [k for k in live if f - tracks[k]["last"] <= max_gap]
        matched_pts: set[int] = set()
        if live and len(pts):
            gaps = np.array([f - tracks[k]["last"] for k in live], float)[:, None] * dt
            last = np.array([tracks[k]["pos"][-1] for k in live])
            vel = np.array([tracks[k]["v"] for k in live])
            pred = last + vel * gaps + 0.5 * GRAVITY * gaps**2
            cost = np.linalg.norm(pred[:, None, :] - pts[None, :, :], axis=2)
            limit = gate + 1.0 * gaps  # a ball unseen longer may have strayed further
            rows, cols = linear_sum_assignment(np.where(cost <= limit, cost, 1e6))
            for r, c in zip(rows, cols):
                if cost[r, c] > limit[r, 0]:
                    continue
                tr = tracks[live[r]]
                step = (f - tr["last"]) * dt
                new_v = (pts[c] - tr["pos"][-1]) / step
                tr["v"] = new_v if len(tr["pos"]) > 1 else new_v
                tr["frames"].append(f)
                tr["pos"].append(pts[c])
                tr["last"] = f
                matched_pts.add(int(c))
        for c in range(len(pts)):
            if c not in matched_pts:
                tracks.append({"frames": [f], "pos": [pts[c]], "v": np.zeros(3), "last": f})
                live.append(len(tracks) - 1)
    out = []
    for tr in tracks:
        frames = np.array(tr["frames"])
        pos = np.array(tr["pos"])
        full = np.full((n_frames, 3), np.nan)
        span = np.arange(frames[0], frames[-1] + 1)
        for axis in range(3):
            full[span, axis] = np.interp(span, frames, pos[:, axis])
        out.append(full)
    return out


def link_balls(
    capture: MocapCapture, n_balls: int | None = None, gate: float = 0.04, max_gap: int = 30, min_length: int = 30
) -> BallCapture:
    """The capture's unnamed markers as ball trajectories (F x B x 3, NaN = not known).

    Linked tracks shorter than ``min_length`` frames (ghost markers) are
    dropped; the rest are packed into ``n_balls`` lanes (default: the most
    balls seen at once), each new track going to the free lane whose last
    position is nearest, so a lane is one ball for as long as the capture
    can tell.
    """
    tracks = [t for t in link_points(capture.unnamed, capture.frequency, gate, max_gap) if np.isfinite(t[:, 0]).sum() >= min_length]
    if not tracks:
        raise StereotrackError("no ball trajectories found in the capture")
    seen = np.isfinite(capture.unnamed[..., 0]).sum(axis=1)
    lanes_n = int(n_balls or np.percentile(seen, 95))
    spans = [(int(np.flatnonzero(np.isfinite(t[:, 0]))[0]), int(np.flatnonzero(np.isfinite(t[:, 0]))[-1]), t) for t in tracks]
    spans.sort(key=lambda s: s[0])
    F = len(capture.times)
    positions = np.full((F, lanes_n, 3), np.nan)
    lane_end = np.full(lanes_n, -1)
    lane_last = np.full((lanes_n, 3), np.nan)
    for start, end, t in spans:
        free = np.flatnonzero(lane_end < start)
        if not len(free):
            continue  # more simultaneous tracks than balls: a ghost, drop it
        unused = free[np.isnan(lane_last[free, 0])]
        if len(unused):
            lane = unused[0]
        else:
            lane = free[np.argmin(np.linalg.norm(lane_last[free] - t[start], axis=1))]
        positions[start : end + 1, lane] = t[start : end + 1]
        lane_end[lane] = end
        lane_last[lane] = t[end]
    return BallCapture(times=capture.times.copy(), positions=positions)


def load_juggling(path: str | Path | None = None, n_balls: int | None = None) -> BallCapture:
    """The 5-ball juggling capture as linked ball trajectories (300 Hz, metres, z up)."""
    return link_balls(read_qualisys_tsv(path or find_real_data(JUGGLING_5)), n_balls=n_balls)
