"""The rerun viewer sink: cameras, images, particles, objects, tracks and time series.

The viewer package is the only one that imports rerun, and only when a
viewer output is asked for: importing it costs nothing, ``RerunSink`` loads rerun.

Entity layout (what the README's viewer section explains)::

    world                          the rig's world frame (RDF when it is a camera's frame, else z up)
    world/cameras/<cam>            Transform3D camera-from-world (OpenCV R, t) + Pinhole (K)
    world/cameras/<cam>/image      the camera image (JPEG or raw)
    world/cameras/<cam>/mask       colour masks, one class id per target (optional)
    world/cameras/<cam>/evidence   what the observation model kept of them: colour or motion (with the masks)
    world/cameras/<cam>/objects    clusters projected into the image: boxes of the ball's image size
    world/cameras/<cam>/tracks     confirmed tracks projected into the image, labelled
    world/particles/<target>       particles, coloured by cluster; class 0 sequential, 1 abductive
    world/rays/<target>/<cam>      abduction viewing rays (optional)
    world/objects                  clusters this frame (points)
    world/tracks                   confirmed tracks: spheres of the ball's radius, labelled
    world/tracks/covariance        2-sigma position covariance ellipsoids
    world/tracks/trails            the last seconds of every track, fading
    world/truth                    ground truth, when the recording has truth.csv
    stats/...                      time series (counts, per-stage ms, rate, error)

Two timelines: ``frame`` (the frame pair's index) and ``capture_time`` (seconds
since the first logged frame, from the pair's capture timestamps).

Cost: the tracker's thread only queues each FrameResult; a logging thread
encodes the JPEGs and gathers logged frames, then sends them as columns, one
``send_columns`` per entity for a batch of frames (a quarter of a second's
when a viewer watches live, more when only a file is written). What never
changes (radii, fill modes,
media type) is logged once, static. BENCHMARKS.md, ``viewer``, has the figures.
"""

from __future__ import annotations

import queue
import subprocess
import sys
import threading
import time
from collections import deque
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np

from ...camera import Rig
from ...capture.signals import StopOnSignals, output_kept, stop_requested
from ...config import Config
from ...console import info
from ...errors import StereotrackError
from ...results import FrameResult
from ..tracks_csv import frames_of_hits, hold_for
from .columns import ColumnWriter, Pending, SeriesBuffer, Trail
from .process import FLUSH_SECONDS, finish_outlets, flush_bounded, open_outlets
from .style import (
    ABDUCTIVE,
    APPLICATION_ID,
    SEQUENTIAL,
    TargetStyle,
    default_blueprint,
    with_alpha,
)

# Logged frames are sent to rerun as columns: one send_columns per entity for what is pending once the first
# frame has waited BATCH_SECONDS (a live viewer's extra latency: ~8 frames of a 30 frames/s camera), or for
# BATCH frames when they come faster. A call costs about the same for 1 frame as for 90, so when only a file
# is written (nobody watches the latency) batches are bigger: the logging thread's Python time, which holds
# the GIL against the tracker, is a third lower at 90 frames than at 30.
BATCH, BATCH_SECONDS = 30, 0.25  # a viewer watches (--spawn, --connect, --serve)
FILE_BATCH, FILE_BATCH_SECONDS = 90, 5.0  # only a file
QUEUE = 8  # frames the logging thread may lag behind the tracker before write() waits


@dataclass(frozen=True)
class VizSettings:
    """What the viewer logs, and how much (cost control)."""

    every: int = 1  # log every N-th frame (trails still follow every frame)
    max_particles: int = 500  # per target and frame; more are subsampled at random (seeded)
    images: bool = True  # log the camera images
    jpeg_quality: int = 75  # JPEG-compress images at this quality (1..100); 0 logs raw BGR pixels
    image_scale: float = 0.5  # log images at this fraction of their size (0 < s <= 1); overlays keep the camera's pixels
    masks: bool = False  # log the colour masks as a layer over each image
    rays: bool = False  # log the abduction's viewing rays
    trail_seconds: float = 2.0  # length of each track's fading trail
    seed: int = 0  # for the particle subsample
    skip_when_behind: bool = False  # live: skip a frame rather than wait when logging lags (recordings: keep every frame)


@dataclass(frozen=True)
class VizOutputs:
    """Where the log goes: any combination of a file, a local viewer, a remote viewer, a web server."""

    rrd: Path | None = None  # save to this .rrd file
    spawn: bool = False  # start a native viewer on this machine
    connect: str | None = None  # stream to a viewer's gRPC server, rerun+http://HOST:PORT/proxy
    serve: bool = False  # host gRPC + web viewer (a child `rerun --serve-web` process)
    bind: str = "127.0.0.1"  # address the served viewer listens on
    grpc_port: int = 9876
    web_port: int = 9090
    hold: bool = True  # with serve: keep serving after a finished run until Ctrl-C

    @property
    def any(self) -> bool:
        return bool(self.rrd or self.spawn or self.connect or self.serve)


# --------------------------------------------------------------------------- the sink


class RerunSink:
    """Logs every FrameResult to rerun (a Sink, see results.py).

    >>> sink = RerunSink(rig, config, VizOutputs(rrd=Path("run.rrd")))
    >>> sink.write(result); ...; sink.close()
    """

    def __init__(
        self,
        rig: Rig,
        config: Config,
        outputs: VizOutputs,
        settings: VizSettings = VizSettings(),
        truth: np.ndarray | None = None,
        recording_name: str | None = None,
    ):
        import rerun as rr

        self.rr = rr
        self.rig = rig
        self.config = config
        self.settings = settings
        self.outputs = outputs
        self._rng = np.random.default_rng(settings.seed)
        self.style = TargetStyle(config.targets)
        self._truth = self._index_truth(truth)
        self._truth_labels = [f"truth {int(o)}" for o in self._truth[0][:, 1]] if self._truth is not None else []
        import cv2

        self._jpeg_params = [cv2.IMWRITE_JPEG_QUALITY, int(settings.jpeg_quality)]
        if not 0 < settings.image_scale <= 1:
            raise StereotrackError(f"image scale must be in (0, 1], got {settings.image_scale}")
        # The size each camera's image is logged at; 2x smaller: bilinear is the 2x2 mean, and cheaper than INTER_AREA.
        self._image_sizes = [
            (max(1, round(c.width * settings.image_scale)), max(1, round(c.height * settings.image_scale))) for c in rig.cameras
        ]
        self._resize = cv2.INTER_LINEAR if settings.image_scale >= 0.5 else cv2.INTER_AREA
        self._children: list[subprocess.Popen] = []
        self._n_written = 0
        self.skipped = 0  # frames not logged because logging lagged (skip_when_behind)
        self._t0: float | None = None
        self._last_wall: float | None = None
        self._rates: deque[float] = deque(maxlen=30)  # wall-clock time between written frames, for frames/s
        self._trails: dict[int, Trail] = {}
        self._closed = False
        self.web_url: str | None = None
        # Logging runs in its own thread so that it overlaps the tracker (JPEG encoding and rerun's
        # Rust side release the GIL); the bounded queue keeps every frame and caps the lag.
        self._queue: queue.Queue = queue.Queue(maxsize=QUEUE)
        self._worker_error: BaseException | None = None
        self._worker = threading.Thread(target=self._work, name="rerun-sink", daemon=True)

        self.rec = rr.RecordingStream(APPLICATION_ID)
        self.rec.set_log_time_enabled(False)  # our own two timelines suffice; the wall-clock one doubles each log call's cost
        if recording_name:
            self.rec.send_recording_name(recording_name)
        self.blueprint = default_blueprint(rig, with_truth=self._truth is not None)
        self._outlets = open_outlets(rr, outputs)  # refuses a missing viewer or a taken port before anything is written
        self._children = self._outlets.children
        self.web_url = self._outlets.web_url
        if self.web_url:
            info(f"web viewer: {self.web_url}")
        self.rec.set_sinks(*self._outlets.sinks, default_blueprint=self.blueprint)
        self._log_static()
        self.columns = ColumnWriter(
            rr, self.rec, rig, config.tracker.window, self.style, settings.trail_seconds, self._truth, self._truth_labels
        )
        self._subsets: dict[int, np.ndarray] = {}  # population size -> the particles logged
        self._series = SeriesBuffer(rr, self.columns.rows)
        self._batch: list[Pending] = []  # logged frames not sent yet (the logging thread's own)
        # The logged frames of the last seconds tracks.csv holds, by frame time: a track confirmed now joins the frames
        # of its first hits (TrackEstimate.before), as in tracks.csv; those already sent are sent again (``_amend``).
        self._recent: deque[tuple[float, Pending]] = deque()
        self._hindsight = hold_for(config.tracks)
        self._batch_started = 0.0  # time.monotonic() when the first of them arrived
        watched = outputs.spawn or outputs.connect or outputs.serve
        self._batch_frames, self._batch_seconds = (BATCH, BATCH_SECONDS) if watched else (FILE_BATCH, FILE_BATCH_SECONDS)
        self._worker.start()

    # ----------------------------------------------------------------- setup

    def _log_static(self) -> None:
        rr, rec = self.rr, self.rec
        if self.rig.world in self.rig.names:  # the world is a camera's frame: OpenCV's x right, y down, z forward
            rec.log("world", rr.ViewCoordinates.RDF, static=True)
        else:  # a custom world (synthetic scenes): z up
            rec.log("world", rr.ViewCoordinates.RIGHT_HAND_Z_UP, static=True)
        for cam in self.rig.cameras:
            path = f"world/cameras/{cam.name}"
            # x_cam = R x_world + t: the transform maps the parent (world) into the camera's frame.
            rec.log(path, rr.Transform3D(translation=cam.t, mat3x3=cam.R, relation=rr.TransformRelation.ChildFromParent), static=True)
            rec.log(
                path,
                rr.Pinhole(
                    image_from_camera=cam.K,
                    resolution=[cam.width, cam.height],
                    camera_xyz=rr.ViewCoordinates.RDF,
                    image_plane_distance=0.12,
                ),
                static=True,
            )
            masks = [rr.AnnotationInfo(id=0, label="background", color=(0, 0, 0, 0))]
            masks += [
                rr.AnnotationInfo(id=i + 1, label=t.name, color=(*self.style.colours[t.name], 140))
                for i, t in enumerate(self.config.targets)
            ]
            rec.log(f"{path}/mask", rr.AnnotationContext(masks), static=True)
            rec.log(f"{path}/evidence", rr.AnnotationContext(masks), static=True)
        rec.log(
            "world/particles",
            rr.AnnotationContext(
                [rr.AnnotationInfo(id=SEQUENTIAL, label="sequential"), rr.AnnotationInfo(id=ABDUCTIVE, label="abductive")]
            ),
            static=True,
        )
        # What never changes is logged once, static; the batches carry only what changes from frame to frame.
        for cam, (w, h) in zip(self.rig.cameras, self._image_sizes):
            path = f"world/cameras/{cam.name}"
            if self.settings.images and self.settings.jpeg_quality > 0:
                rec.log(f"{path}/image", rr.EncodedImage.from_fields(media_type="image/jpeg"), static=True)
            if self.settings.images and (w, h) != (cam.width, cam.height):  # a smaller image drawn over the camera's full pixel grid
                rec.log(f"{path}/image", rr.Transform3D(scale=[cam.width / w, cam.height / h, 1.0]), static=True)
            rec.log(f"{path}/tracks", rr.Points2D.from_fields(radii=4.0), static=True)
        rec.log("world/objects", rr.Points3D.from_fields(radii=0.01, show_labels=False), static=True)
        rec.log("world/tracks", rr.Ellipsoids3D.from_fields(fill_mode=rr.components.FillMode.Solid), static=True)
        rec.log("world/tracks/covariance", rr.Ellipsoids3D.from_fields(fill_mode=rr.components.FillMode.MajorWireframe), static=True)
        rec.log("world/tracks/trails", rr.LineStrips3D.from_fields(radii=0.004), static=True)
        if self._truth is not None:
            rec.log("world/truth", rr.Points3D.from_fields(colors=[255, 255, 255], radii=0.008, show_labels=False), static=True)

    @staticmethod
    def _index_truth(truth: np.ndarray | None) -> tuple[np.ndarray, np.ndarray] | None:
        """Truth rows sorted by frame, plus the frame column for slicing one frame at a time."""
        if truth is None or len(truth) == 0:
            return None
        truth = np.asarray(truth, dtype=float)
        truth = truth[np.argsort(truth[:, 0], kind="stable")]
        return truth, truth[:, 0]

    # ----------------------------------------------------------------- per frame

    def write(self, result: FrameResult) -> None:
        """Hand the frame to the logging thread; blocks only when it is QUEUE frames behind."""
        self._check_worker()
        frame = result.frame
        if self._t0 is None:
            self._t0 = frame.time
        self._n_written += 1
        log = (self._n_written - 1) % self.settings.every == 0
        fps = None
        if log:  # the loop's pace, measured here in the tracker's thread
            wall = time.perf_counter()
            if self._last_wall is not None:
                self._rates.append((wall - self._last_wall) / self.settings.every)
                fps = len(self._rates) / max(sum(self._rates), 1e-9)
            self._last_wall = wall
        item = (result, frame.time - self._t0, log, fps)
        if self.settings.skip_when_behind:
            if log and self._queue.qsize() > 0:  # the logging thread is still busy: only the trails follow this frame
                item = (result, item[1], False, None)
            try:
                self._queue.put_nowait(item)
            except queue.Full:  # far behind: not even the trails get this frame
                item = None
            if log and (item is None or not item[2]):
                self.skipped += 1
            return
        while True:
            try:
                self._queue.put(item, timeout=0.5)
                return
            except queue.Full:
                self._check_worker()

    def _check_worker(self) -> None:
        if self._worker_error is not None:
            error, self._worker_error = self._worker_error, None
            raise RuntimeError(f"rerun logging failed: {type(error).__name__}: {error}") from error
        if self._closed:
            raise RuntimeError("RerunSink.write after close")

    def _work(self) -> None:
        """The logging thread: rerun's time is per thread, so every timed log call happens here.

        Logged frames are gathered and sent as columns once a batch's worth
        are pending, or once the first has waited its time (a slow camera).
        """
        while True:
            timeout = None if not self._batch else max(0.0, self._batch_started + self._batch_seconds - time.monotonic())
            try:
                item = self._queue.get(timeout=timeout)
            except queue.Empty:  # nothing new for a while: send what is pending
                self._guarded(self._flush)
                continue
            if item is None:
                self._guarded(self._flush)
                return
            self._guarded(self._log_frame, *item)

    def _guarded(self, fn, *args) -> None:
        if self._worker_error is not None:
            return  # keep draining so the tracker never blocks on a dead logger
        try:
            fn(*args)
        except Exception as exc:  # reported to the tracker's thread on its next write or close
            self._worker_error = exc

    def _log_frame(self, result: FrameResult, now: float, log: bool, fps: float | None) -> None:
        """One frame in the logging thread: the trails follow it, its revisions amend the logged frames; a logged frame
        joins the batch."""
        self._follow_trails(result, now)
        # Revisions of logged frames (a track confirmed, a state smoothed) come with any frame, logged or not.
        self._amend(result)
        if not log:
            return
        s = self.settings
        if (s.images and s.jpeg_quality == 0) or s.masks or s.rays:  # the optional heavy layers: logged at once, row by row
            self.rec.set_time("frame", sequence=result.frame.index)
            self.rec.set_time("capture_time", duration=now)
            self._log_extras(result)
        if not self._batch:
            self._batch_started = time.monotonic()
        pending = self._gather(result, now)
        self._batch.append(pending)
        self._recent.append((result.frame.time, pending))
        while self._recent and self._recent[0][0] < result.frame.time - self._hindsight:
            self._recent.popleft()
        self._log_stats(result, now, fps)
        if len(self._batch) >= self._batch_frames or time.monotonic() - self._batch_started >= self._batch_seconds:
            self._flush()

    def _gather(self, result: FrameResult, now: float) -> Pending:
        """What a logged frame contributes to its batch; the arrays are built once per batch in _send."""
        s = self.settings
        confirmed = result.confirmed
        jpegs = self._encode_images(result) if s.images and s.jpeg_quality > 0 else []
        offsets: dict[str, int] = {}  # index of each target's first object: particle labels count per target
        for i, obj in enumerate(result.objects):
            offsets.setdefault(obj.target, i)
        particles = []
        for ps in result.particles:
            keep = self._subsample(len(ps.positions))
            particles.append((ps.target, ps.positions[keep], ps.labels[keep], ps.abductive[keep], offsets.get(ps.target, 0)))
        trails = []
        for k, t in enumerate(confirmed):
            trail = self._trails.get(t.track_id)
            if trail is not None and len(trail) >= 2:
                trails.append((k, *trail.arrays()))  # views: a Trail never rewrites points it has handed out
        return Pending(result.frame.index, now, result.objects, confirmed, jpegs, particles, trails)

    def _subsample(self, n: int) -> np.ndarray | slice:
        """Which of n particles to log: all up to max_particles, else a seeded random subset of that many.

        The subset is drawn once per population size and reused: each frame's
        resampled population is still shown through a uniform random sample.
        """
        limit = self.settings.max_particles
        if n <= limit:
            return slice(None)
        if n not in self._subsets:
            self._subsets[n] = np.sort(self._rng.choice(n, size=limit, replace=False))
        return self._subsets[n]

    def _encode_images(self, result: FrameResult) -> list[np.ndarray]:
        """Each camera's image, scaled, as JPEG bytes (OpenCV's libjpeg-turbo; it releases the GIL while it encodes)."""
        import cv2

        return [
            cv2.imencode(".jpg", self._scaled(img, ci), self._jpeg_params)[1]
            for ci, img in enumerate(result.frame.images[: len(self.rig.cameras)])
        ]

    def _scaled(self, img: np.ndarray, ci: int) -> np.ndarray:
        """A camera's image at the size it is logged at (VizSettings.image_scale)."""
        import cv2

        size = self._image_sizes[ci]
        return img if (img.shape[1], img.shape[0]) == size else cv2.resize(img, size, interpolation=self._resize)

    def _amend(self, result: FrameResult) -> None:
        """Add each track confirmed this frame to the logged frames of its first hits (its tentative ones), and put each
        track's smoothed state in its logged frame of that time, as tracks.csv writes them; frames already sent are sent
        again with it (the viewer shows a time's later row)."""
        sent = []
        for t in result.confirmed:  # a hit without its frame here: not logged (a live frame skipped)
            for (_, pending), (_, position, covariance, n_particles) in frames_of_hits(self._recent, t.before):
                early = replace(t, position=position, covariance=covariance, n_particles=n_particles, state="confirmed", before=())
                pending.tracks = (*pending.tracks, early)
                sent.append(pending)
        for t in result.tracks:
            for (_, pending), (_, position, covariance, fill) in frames_of_hits(self._recent, t.smoothed):
                if any(shown.track_id == t.track_id for shown in pending.tracks):  # (ids are unique across targets)
                    pending.tracks = tuple(
                        replace(shown, position=position, covariance=covariance) if shown.track_id == t.track_id else shown
                        for shown in pending.tracks
                    )
                    sent.append(pending)
                elif fill:  # a frame it coasted through unreported, its ball met again since (as tracks.csv writes it)
                    filled = replace(
                        t, position=position, covariance=covariance, n_particles=0, state="coasting", reported=True, before=(), smoothed=()
                    )
                    pending.tracks = (*pending.tracks, filled)
                    sent.append(pending)
        sent = [p for p in sent if all(p is not b for b in self._batch)]
        if sent:
            self.columns.send_tracks(sorted({id(p): p for p in sent}.values(), key=lambda p: p.index))

    def _flush(self) -> None:
        batch, self._batch = self._batch, []
        if batch:
            self.columns.send(batch)
        self._series.flush()

    def _log_extras(self, result: FrameResult) -> None:
        """Raw images, colour masks and viewing rays: off by default, logged per frame."""
        rr, rec, s = self.rr, self.rec, self.settings
        for ci, cam in enumerate(self.rig.cameras):
            path = f"world/cameras/{cam.name}"
            if s.images and s.jpeg_quality == 0 and ci < len(result.frame.images):
                rec.log(f"{path}/image", rr.Image(self._scaled(result.frame.images[ci], ci), color_model="BGR"))
            if s.masks:
                self._log_mask(result, cam.name, path, (cam.width, cam.height))
        if s.rays:
            self._log_rays(result)

    def _log_mask(self, result: FrameResult, cam_name: str, path: str, size: tuple[int, int]) -> None:
        """Two layers: ``mask``, the pixels in each target's HSV range (before), and ``evidence``, those the
        observation model counts (after: colour likelier on the ball than in the room, or moving)."""
        for entity, masks in (("mask", result.masks), ("evidence", result.evidence)):
            label = None
            for i, target in enumerate(self.config.targets):
                mask = masks.get((target.name, cam_name))
                if mask is None:
                    continue
                if label is None:
                    label = np.zeros(mask.shape[:2], dtype=np.uint8)
                label[mask > 0] = i + 1
            if label is not None:
                if label.shape[::-1] != size:  # evidence built on a coarser grid (evidence_scale): shown at the camera's pixels
                    import cv2

                    label = cv2.resize(label, size, interpolation=cv2.INTER_NEAREST)
                self.rec.log(f"{path}/{entity}", self.rr.SegmentationImage(label, opacity=0.5))

    def _follow_trails(self, result: FrameResult, now: float) -> None:
        live = {t.track_id for t in result.tracks}
        for tid in [tid for tid in self._trails if tid not in live]:
            del self._trails[tid]
        for t in result.tracks:
            self._trails.setdefault(t.track_id, Trail()).add(now, t.position, self.settings.trail_seconds)

    def _log_rays(self, result: FrameResult) -> None:
        d_min, d_max = self.config.tracker.d_min, self.config.tracker.d_max
        for rays in result.rays:
            strips = np.stack([rays.origins + d_min * rays.directions, rays.origins + d_max * rays.directions], axis=1)
            self.rec.log(
                f"world/rays/{rays.target}/{rays.camera}",
                self.rr.LineStrips3D(strips, colors=with_alpha(self.style.colour(rays.target), np.full(len(strips), 0.6)), radii=0.002),
            )

    def _log_stats(self, result: FrameResult, now: float, fps: float | None) -> None:
        frame = result.frame.index

        def add(path: str, value: float) -> None:
            self._series.add(path, frame, now, value)

        confirmed = result.confirmed
        for t in confirmed:
            add(f"stats/counts/particles/track_{t.track_id}", t.n_particles)
        for name in self.style.targets:
            add(f"stats/counts/objects/{name}", sum(o.target == name for o in result.objects))
        add("stats/counts/confirmed_tracks", len(confirmed))
        for stage, ms in result.timings_ms.items():
            add(f"stats/timing_ms/{stage}", ms)
        if fps is not None:  # the whole loop (decode, track, sinks), over the last logged frames
            add("stats/rate/frames_per_s", fps)
        if result.timings_ms.get("step"):  # the tracker's own step alone
            add("stats/rate/tracker_frames_per_s", 1000.0 / result.timings_ms["step"])
        if result.latency_s is not None:
            add("stats/rate/latency_ms", 1000.0 * result.latency_s)
        if self._truth is not None and confirmed:  # distance from each confirmed track to its nearest true ball
            truth, truth_frames = self._truth
            lo, hi = np.searchsorted(truth_frames, [frame, frame + 1])
            if hi > lo:
                d = np.array([t.position for t in confirmed])[:, None, :] - truth[None, lo:hi, 2:5]
                dist = np.sqrt((d * d).sum(axis=2).min(axis=1))
                add("stats/error_mm/mean", 1000.0 * float(dist.mean()))
                add("stats/error_mm/max", 1000.0 * float(dist.max()))

    # ----------------------------------------------------------------- end

    def close(self) -> None:
        """Finish the log, also after Ctrl-C, in bounded time: the .rrd gets its footer and its name, a viewer
        what it takes within FLUSH_SECONDS; our viewer servers stop. A run that failed leaves no .rrd."""
        if self._closed:
            return
        self._closed = True
        ended_cleanly = sys.exc_info()[1] is None  # no error, no stop on its way out: a held viewer may keep serving
        kept = output_kept()  # asked now: an error raised while closing is not the run's
        try:
            try:
                self._queue.put(None, timeout=FLUSH_SECONDS)  # after the frames already queued: all of them reach the file
            except queue.Full:
                self._worker_error = self._worker_error or TimeoutError("the logging thread is stuck")
            self._worker.join(FLUSH_SECONDS)
            flush_bounded(self.rec, self._outlets)
            if self.outputs.serve and self.outputs.hold and ended_cleanly and self.web_url and not stop_requested():
                info(f"the web viewer keeps serving at {self.web_url} ; press Ctrl-C to stop")
                try:
                    with StopOnSignals() as held:  # one Ctrl-C (or SIGTERM) ends the hold
                        while not held.requested and all(p.poll() is None for p in self._children if "--serve-web" in p.args):
                            time.sleep(0.2)
                except KeyboardInterrupt:
                    pass
        finally:
            finish_outlets(self.rec, self._outlets, keep_rrd=kept)
        if self._worker_error is not None:
            error = self._worker_error
            raise RuntimeError(f"rerun logging failed: {type(error).__name__}: {error}") from error

    @property
    def rrd_path(self) -> Path | None:
        """The .rrd file being written, if any."""
        return Path(self.outputs.rrd) if self.outputs.rrd is not None else None

    def __enter__(self) -> RerunSink:
        return self

    def __exit__(self, *exc) -> None:
        self.close()
