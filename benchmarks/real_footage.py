"""Does the 2D evidence find a real ball? Hand labels on real single-camera footage, any evidence function.

The bundled videos (../shared/data/real/ball-videos: a pale green ball held,
moved and thrown by hand against light walls; motion blur, compression,
uneven light) have hand-checked labels for every 10th frame in
tests/data/ball-videos/labels.csv: the ball's centre and radius, or "no
ball". An evidence function sees every frame of a video in order (so a
background model can learn) and returns blobs: centres (M x 2 pixels) and
radii (M). At each labelled frame a blob whose centre lies inside the
labelled circle is on the ball; every other blob is false. Reported per
video and overall: the share of ball frames where some blob is on the ball,
false blobs per frame, and the share of frames with any false blob.

The paper's evidence is the HSV mask + connected-component blobs, with the
video author's own range (H 30..100, S 30..150, V 30..150) and with what a
user would type for this ball (its hue +-10, S and V from 80 up); the
observation model's (``model_evidence``) is measured on both ranges beside it.

    .venv/bin/python benchmarks/real_footage.py                 # table to stdout
    .venv/bin/python benchmarks/real_footage.py --docs docs/evaluation.md
"""

from __future__ import annotations

import argparse
import csv
import sys
from collections.abc import Callable
from dataclasses import dataclass
from datetime import UTC, datetime
from pathlib import Path

import cv2
import numpy as np

ROOT = Path(__file__).resolve().parent.parent
LABELS = ROOT / "tests" / "data" / "ball-videos" / "labels.csv"

Blobs2D = tuple[np.ndarray, np.ndarray]  # centres M x 2, radii M
Evidence = Callable[[np.ndarray], Blobs2D]  # one BGR frame -> blobs; called for every frame in order


@dataclass(frozen=True)
class Label:
    video: str
    frame: int
    ball: bool
    x: float = float("nan")
    y: float = float("nan")
    radius: float = float("nan")
    partial: bool = False


def load_labels(path: str | Path = LABELS) -> list[Label]:
    out = []
    with open(path, newline="") as f:
        for row in csv.DictReader(f):
            ball = row["ball"] == "1"
            out.append(
                Label(
                    row["video"],
                    int(row["frame"]),
                    ball,
                    *(float(row[k]) for k in ("x", "y", "radius")) if ball else (float("nan"),) * 3,
                    partial=row.get("partial") == "1",
                )
            )
    return out


def hsv_evidence(hsv_min, hsv_max, min_area: int = 6) -> Callable[[], Evidence]:
    """Today's evidence: the target's HSV mask, then connected-component blobs (the tracker's own functions)."""
    from stereotrack.config import Target
    from stereotrack.evidence.blobs import find_blobs
    from stereotrack.evidence.colour import target_mask, to_hsv

    target = Target("ball", tuple(hsv_min), tuple(hsv_max))

    def make() -> Evidence:
        def evidence(image: np.ndarray) -> Blobs2D:
            blobs = find_blobs(target_mask(to_hsv(image), target), "components", min_area)
            return blobs.centres, blobs.radii

        return evidence

    return make


def model_evidence(hsv_min, hsv_max, min_area: int = 6, radius: float = 0.035, fov_deg: float = 60.0) -> Callable[[], Evidence]:
    """The observation model's 2D evidence (issue 14): the range sharpened by a colour model learnt against the
    room, its moving part from a background model, and only blobs that could be a ball seed particles (the
    seeds are the blobs returned). The videos have no calibration: a webcam's 60-degree field of view and a
    ball of ``radius`` metres at 0.2-5 m stand in, as `stereotrack.config`'s defaults would. The evidence is built
    on the grid the tracker would build it on (tracker.evidence_scale, automatic: every other pixel of ball4.mp4's
    1280x720), and its blobs are returned in the video's pixels."""
    from stereotrack.camera import Camera, intrinsics_from_fov
    from stereotrack.config import Target, TrackerSettings
    from stereotrack.evidence.colour import target_mask, to_hsv
    from stereotrack.evidence.colour_model import ColourModel
    from stereotrack.evidence.gather import CameraEvidence, every_nth, on_grid
    from stereotrack.evidence.motion import BackgroundModel
    from stereotrack.pipeline.tracker import evidence_scale

    target = Target("ball", tuple(hsv_min), tuple(hsv_max), radius)
    s = TrackerSettings()

    def make() -> Evidence:
        state: dict = {}

        def evidence(image: np.ndarray) -> Blobs2D:
            if not state:
                h, w = image.shape[:2]
                full = Camera("cam0", (w, h), intrinsics_from_fov(w, h, fov_deg), np.zeros(5), np.eye(3), np.zeros(3))
                k = evidence_scale(s, full, radius)
                cam = on_grid(full, k)
                state.update(camera=cam, scale=k, background=BackgroundModel(cam, s.background_rate, s.foreground_threshold))
                state["colour"] = ColourModel.for_target(target)
            k = state["scale"]
            image = every_nth(image, k)
            hsv = to_hsv(image)
            mask = target_mask(hsv, target)
            table = state["colour"].table(hsv)
            state["colour"].learn(hsv, mask)  # no tracks here: the room's colours only
            ev = CameraEvidence.from_mask(
                state["camera"], mask, None, "components", max(1, round(min_area / (k * k))), state["background"].update(image),
                (radius, s.d_min, s.d_max), table, hsv,
            )  # fmt: skip
            seeds = ev.proposal_seeds()
            return seeds.centres * k, seeds.radii * k  # the video's pixels, as the tracker shows its rays

        return evidence

    return make


@dataclass(frozen=True)
class Score:
    ball_frames: int
    found: int  # ball frames with a blob on the ball
    frames: int
    false_blobs: int
    frames_with_false: int
    false_radius_sum: float = 0.0  # pixels, over the false blobs

    @property
    def false_radius(self) -> float:
        return self.false_radius_sum / self.false_blobs if self.false_blobs else float("nan")

    @property
    def found_share(self) -> float:
        return self.found / self.ball_frames if self.ball_frames else float("nan")

    @property
    def false_per_frame(self) -> float:
        return self.false_blobs / self.frames if self.frames else float("nan")

    def __add__(self, other: Score) -> Score:
        return Score(*(a + b for a, b in zip(self.__dict__.values(), other.__dict__.values())))


def score_frame(label: Label, centres: np.ndarray) -> tuple[bool, np.ndarray]:
    """(a blob is on the ball, which blobs are false) at one labelled frame."""
    centres = np.asarray(centres, float).reshape(-1, 2)
    if not label.ball:
        return False, np.ones(len(centres), bool)
    on = np.hypot(centres[:, 0] - label.x, centres[:, 1] - label.y) <= label.radius
    return bool(on.any()), ~on


def find_videos() -> Path | None:
    """The folder holding the videos: $STEREOTRACK_REAL_DATA/ball-videos, or the project's shared real-data folder
    beside the repository (or beside the folder of worktrees it is in); None if there is none."""
    from stereotrack.errors import StereotrackError
    from stereotrack.simulation.mocap import find_real_data

    try:
        return find_real_data("ball-videos/ball2.mp4").parent
    except StereotrackError:
        pass
    for up in (ROOT.parent, ROOT.parent.parent):
        folder = up / "shared" / "data" / "real" / "ball-videos"
        if (folder / "ball2.mp4").is_file():
            return folder
    return None


def measure(make_evidence: Callable[[], Evidence], labels: list[Label], videos: Path) -> dict[str, Score]:
    """Per video: run a fresh evidence function over every frame, score the labelled ones."""
    out = {}
    for video in dict.fromkeys(lab.video for lab in labels):
        wanted = {lab.frame: lab for lab in labels if lab.video == video}
        cap = cv2.VideoCapture(str(videos / video))
        if not cap.isOpened():
            raise SystemExit(f"cannot open {videos / video}")
        evidence = make_evidence()
        s = Score(0, 0, 0, 0, 0, 0.0)
        i = 0
        while wanted and i <= max(wanted):
            ok, frame = cap.read()
            if not ok:
                break
            centres, radii = evidence(frame)
            lab = wanted.get(i)
            if lab is not None:
                found, false = score_frame(lab, centres)
                n = int(false.sum())
                s = s + Score(int(lab.ball), int(found), 1, n, int(n > 0), float(np.asarray(radii, float)[false].sum()))
            i += 1
        cap.release()
        out[video] = s
    return out


def whole_ball_frames(labels: list[Label], videos: Path):
    """(label, HSV frame, the ball's inner disc: 0.6 of its radius) at each labelled frame that shows the whole ball."""
    for video in dict.fromkeys(lab.video for lab in labels):
        wanted = {lab.frame: lab for lab in labels if lab.video == video and lab.ball and not lab.partial}
        cap = cv2.VideoCapture(str(videos / video))
        i = 0
        while wanted and i <= max(wanted):
            ok, frame = cap.read()
            if not ok:
                break
            lab = wanted.get(i)
            if lab is not None:
                hsv = cv2.cvtColor(frame, cv2.COLOR_BGR2HSV)
                yy, xx = np.mgrid[0 : hsv.shape[0], 0 : hsv.shape[1]]
                yield lab, hsv, np.hypot(xx - lab.x, yy - lab.y) <= 0.6 * lab.radius
            i += 1
        cap.release()


def typed_range(labels: list[Label], videos: Path) -> tuple[tuple[int, int, int], tuple[int, int, int]]:
    """What a user would type for this ball: its median hue (as a colour picker shows it) +-10, S and V from 80."""
    hues = [np.median(hsv[inner][:, 0]) for _, hsv, inner in whole_ball_frames(labels, videos)]
    h = int(round(float(np.median(hues))))
    return (h - 10, 80, 80), (h + 10, 255, 255)


def range_coverage(labels: list[Label], videos: Path, lo, hi) -> float:
    """The median share of the ball's inner disc inside the range (lo, hi), over the frames that show the whole ball:
    how much of the ball a range lets any evidence see."""
    lo, hi = np.array(lo), np.array(hi)
    shares = [float(np.all((hsv[inner] >= lo) & (hsv[inner] <= hi), axis=1).mean()) for _, hsv, inner in whole_ball_frames(labels, videos)]
    return float(np.median(shares))


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--labels", default=str(LABELS))
    ap.add_argument("--videos", help="folder of ball2.mp4 and ball4.mp4 (default: the shared real-data folder)")
    ap.add_argument("--docs", help="write the table into this markdown file's 'real-footage' section")
    args = ap.parse_args()
    labels = load_labels(args.labels)
    videos = Path(args.videos) if args.videos else find_videos()
    if videos is None:
        raise SystemExit("the ball videos are not found: pass --videos FOLDER or set STEREOTRACK_REAL_DATA")
    # Each video is its own camera and light (the ball's median hue is 46 in ball2.mp4, 60 in ball4.mp4): a user types
    # the range for the video in front of them, so the typed range is picked per video, not over both.
    per_video = {video: [lab for lab in labels if lab.video == video] for video in dict.fromkeys(lab.video for lab in labels)}
    ranges = {video: typed_range(labs, videos) for video, labs in per_video.items()}
    typed = ", ".join(f"{video} H {lo[0]}..{hi[0]}" for video, (lo, hi) in ranges.items())
    coverage = {video: range_coverage(per_video[video], videos, *ranges[video]) for video in per_video}
    author = (30, 30, 30), (100, 150, 150)
    evidence = {
        "HSV + blobs, author's range H 30..100, S 30..150, V 30..150": lambda video: hsv_evidence(*author),
        f"HSV + blobs, typed range S, V 80..255, {typed}": lambda video: hsv_evidence(*ranges[video]),
        f"observation model (colour model, motion, ball-like seeds), typed range {typed}": lambda video: model_evidence(*ranges[video]),
        "observation model, author's range H 30..100, S 30..150, V 30..150": lambda video: model_evidence(*author),
    }
    lines = [
        "| evidence | video | labelled frames (with ball) | ball found | false blobs per frame | frames with a false blob | false blob mean radius (px) |",
        "|---|---|---|---|---|---|---|",
    ]
    for name, make in evidence.items():
        per = {}
        for video, labs in per_video.items():
            per.update(measure(make(video), labs, videos))
        total = sum(per.values(), Score(0, 0, 0, 0, 0, 0.0))
        for video, s in [*per.items(), ("all", total)]:
            lines.append(
                f"| {name} | {video} | {s.frames} ({s.ball_frames}) | {s.found_share:.2f} | {s.false_per_frame:.2f} | {s.frames_with_false / s.frames:.2f} | "
                f"{'' if s.false_blobs == 0 else format(s.false_radius, '.1f')} |"
            )
    table = "\n".join(lines)
    print(table)
    if args.docs:
        from stereotrack.files import replace_section

        n_ball = sum(lab.ball for lab in labels)
        body = [
            "## Real footage: does the 2D evidence find a real ball?",
            "",
            f"Produced by `.venv/bin/python benchmarks/real_footage.py --docs {args.docs}` on {datetime.now(UTC):%Y-%m-%d}.",
            f"Real single-camera footage (`ball-videos`: a pale green ball held, moved and thrown by hand against light walls), "
            f"{len(labels)} hand-checked labelled frames (every 10th; {n_ball} show the ball; tests/data/ball-videos/README.md says how "
            "they were made). The evidence sees every frame in order; at a labelled frame a blob whose centre lies inside the ball's "
            "circle finds the ball, every other blob is false. The typed range is the ball's median hue in that video +-10 with S "
            "and V from 80, what a user would type after picking the ball's colour in it.",
            "",
            table,
            "",
            "How much of the ball the typed range takes in (the median share of its inner disc in range, over the frames that show "
            "the whole ball): " + ", ".join(f"{video} {share:.0%}" for video, share in coverage.items()) + ". The ball is pale: "
            "where the range takes in only a few of its pixels (saturation under 80), HSV + blobs counts a speck "
            "of 6 pixels on it as found, and the observation model seeds no particle from a blob too small to be the ball at "
            "any depth. The author's wider range (the rows above) shows what each finds when the range takes the ball in.",
        ]
        replace_section(args.docs, "real-footage", "\n".join(body))
        print(f"table written to {args.docs} (section 'real-footage')")
    return 0


if __name__ == "__main__":
    sys.exit(main())
