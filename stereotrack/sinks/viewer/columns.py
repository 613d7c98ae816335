"""The sink's column batches: what is gathered per frame (trails, time series, pending frames) and how a batch is sent."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from .style import ABDUCTIVE, PALETTE, PALETTE_RGBA, PARTICLE_RGBA, SEQUENTIAL, TargetStyle, quaternions_xyzw


class Trail:
    """One track's recent positions in growing arrays, trimmed to the trail's length in seconds.

    Points are only ever appended (growing copies them into new arrays), so
    the views ``arrays()`` hands out stay valid while they wait for a batch.
    """

    def __init__(self) -> None:
        self.times = np.zeros(64)
        self.points = np.zeros((64, 3))
        self.start = self.end = 0

    def add(self, t: float, position: np.ndarray, seconds: float) -> None:
        if self.end == len(self.times):  # full: drop what is trimmed, grow if still needed
            n = self.end - self.start
            size = max(64, 2 * n)
            times, points = np.zeros(size), np.zeros((size, 3))
            times[:n], points[:n] = self.times[self.start : self.end], self.points[self.start : self.end]
            self.times, self.points, self.start, self.end = times, points, 0, n
        self.times[self.end] = t
        self.points[self.end] = position
        self.end += 1
        self.start += int(np.searchsorted(self.times[self.start : self.end], t - seconds, side="left"))

    def __len__(self) -> int:
        return self.end - self.start

    def arrays(self) -> tuple[np.ndarray, np.ndarray]:
        return self.times[self.start : self.end], self.points[self.start : self.end]


class SeriesBuffer:
    """Time-series values gathered per entity and sent as columns with the sink's batches.

    One ``send_columns`` per series per batch instead of one ``log`` call per
    value and frame: the time series are most of the log calls, and each call
    costs more than the numbers it carries.
    """

    def __init__(self, rr: Any, send_rows: Any):
        self.rr, self.send_rows = rr, send_rows  # send_rows: RerunSink._rows
        self.series: dict[str, tuple[list[int], list[float], list[float]]] = {}

    def add(self, path: str, frame: int, t: float, value: float) -> None:
        frames, times, values = self.series.setdefault(path, ([], [], []))
        frames.append(frame)
        times.append(t)
        values.append(float(value))

    def flush(self) -> None:
        rr = self.rr
        index: dict[tuple[int, ...], list[Any]] = {}  # most series share the batch's frames: build their time columns once
        for path, (frames, times, values) in self.series.items():
            if frames:
                key = tuple(frames)
                if key not in index:
                    index[key] = [
                        rr.TimeColumn("frame", sequence=np.array(frames, dtype=np.int64)),
                        rr.TimeColumn("capture_time", duration=np.array(times)),
                    ]
                self.send_rows(path, index[key], np.ones(len(values), dtype=np.int64), rr.Scalars, scalars=np.array(values))
        self.series.clear()


@dataclass
class Pending:
    """One logged frame waiting for its batch: references and the few things that cannot wait (JPEGs, trails)."""

    index: int  # frame number
    time: float  # capture_time, s
    objects: tuple  # Object3D
    tracks: tuple  # the confirmed TrackEstimates
    jpegs: list  # per camera, the encoded image (uint8 array)
    particles: list  # per target: (target, positions, labels, abductive, index of its first object)
    trails: list  # per confirmed track with a trail: (its index in tracks, times, points)


class ColumnWriter:
    """Sends a batch of logged frames to rerun: one ``send_columns`` per entity, every array built once for the batch."""

    def __init__(self, rr: Any, rec: Any, rig: Any, window: int, style: TargetStyle, trail_seconds: float, truth, truth_labels) -> None:
        self.rr, self.rec, self.rig = rr, rec, rig
        self.window = window  # the colour window W: an object's box is at least this wide
        self.style = style
        self.trail_seconds = trail_seconds
        self._truth, self._truth_labels = truth, truth_labels  # (rows, frames) sorted by frame; their labels
        self._components: dict[tuple[type, str], tuple[Any, Any]] = {}  # (archetype, field) -> descriptor, batch class

    def send(self, batch: list[Pending]) -> None:
        """Send a batch of logged frames: one send_columns per entity, every array built once for the batch."""
        rr = self.rr
        n = len(batch)
        frames = np.array([b.index for b in batch], dtype=np.int64)
        times = np.array([b.time for b in batch], dtype=float)
        index = [rr.TimeColumn("frame", sequence=frames), rr.TimeColumn("capture_time", duration=times)]

        # Objects: cluster means, coloured by their index in their frame (as their particles).
        objects = [o for b in batch for o in b.objects]
        n_obj = np.array([len(b.objects) for b in batch], dtype=np.int64)
        obj_pos = np.array([o.position for o in objects], dtype=float).reshape(-1, 3)
        obj_rank = np.arange(len(objects)) - np.repeat(np.cumsum(n_obj) - n_obj, n_obj)
        obj_colours = PALETTE_RGBA[obj_rank % len(PALETTE)]
        obj_radii = np.array([self.style.radius(o.target) for o in objects], dtype=float)
        labels = [f"{o.target} {o.n_particles}p" for o in objects]
        self.rows("world/objects", index, n_obj, rr.Points3D, positions=obj_pos, colors=obj_colours, labels=labels)

        tracks, n_trk, centres, colours = self._world_tracks(batch, index)

        # Fading trails: one two-point strip per step, alpha falling with age.
        first_trk = np.cumsum(n_trk) - n_trk
        pieces = [(b.time, first_trk[i] + k, ts, pts) for i, b in enumerate(batch) for k, ts, pts in b.trails]
        if pieces:
            steps = np.array([len(p[2]) - 1 for p in pieces])
            ts = np.concatenate([p[2] for p in pieces])
            pts = np.concatenate([p[3] for p in pieces])
            within = np.ones(len(ts) - 1, dtype=bool)
            within[np.cumsum(steps + 1)[:-1] - 1] = False  # no step from one trail's end to the next one's start
            ends = np.stack([pts[:-1][within], pts[1:][within]], axis=1)
            age = np.repeat([p[0] for p in pieces], steps) - ts[1:][within]
            alpha = np.clip(255.0 * (1.0 - age / max(self.trail_seconds, 1e-9)), 0, 255).astype(np.uint32)
            seg_colours = (np.repeat(colours[[p[1] for p in pieces]], steps) & np.uint32(0xFFFFFF00)) | alpha
            n_seg = np.bincount([i for i, b in enumerate(batch) for _ in b.trails], weights=steps, minlength=n).astype(np.int64)
        else:
            ends, seg_colours, n_seg = np.zeros((0, 2, 3)), np.zeros(0, np.uint32), np.zeros(n, dtype=np.int64)
        self.rows("world/tracks/trails", index, n_seg, rr.LineStrips3D, strips=self.segments(ends), colors=seg_colours)

        # Particles, per target: coloured by cluster; abductive ones lighter and smaller, class 1.
        for target in dict.fromkeys(p[0] for b in batch for p in b.particles):
            mine = [next((p for p in b.particles if p[0] == target), None) for b in batch]
            lengths = np.array([0 if p is None else len(p[1]) for p in mine], dtype=np.int64)
            mine = [p for p in mine if p is not None]
            pos = np.concatenate([p[1] for p in mine])
            labels = np.concatenate([p[2] for p in mine])
            abductive = np.concatenate([p[3] for p in mine]).astype(bool)
            glob = labels + np.repeat([p[4] for p in mine], [len(p[1]) for p in mine])
            shade = np.where(labels >= 0, glob % len(PALETTE), len(PALETTE)) + abductive * (len(PALETTE) + 1)
            self.rows(
                f"world/particles/{target}",
                index,
                lengths,
                rr.Points3D,
                positions=pos,
                colors=PARTICLE_RGBA[shade],
                radii=np.where(abductive, 0.003, 0.005),
                class_ids=np.where(abductive, ABDUCTIVE, SEQUENTIAL).astype(np.uint16),
            )

        if self._truth is not None:
            truth, truth_frames = self._truth
            lo, hi = np.searchsorted(truth_frames, frames), np.searchsorted(truth_frames, frames + 1)
            rows = np.concatenate([np.arange(a, b) for a, b in zip(lo, hi)]).astype(np.int64)
            self.rows("world/truth", index, hi - lo, rr.Points3D, positions=truth[rows, 2:5], labels=[self._truth_labels[i] for i in rows])

        # Each camera: its image, the objects' windows and the tracks' marks, projected for the whole batch at once.
        both, n_objs = np.vstack([obj_pos, centres]), len(objects)
        obj_frame, trk_frame = np.repeat(np.arange(n), n_obj), np.repeat(np.arange(n), n_trk)
        trk_labels = [f"#{t.track_id}" for t in tracks]
        half_window = self.window / 2
        for ci, cam in enumerate(self.rig.cameras):
            path = f"world/cameras/{cam.name}"
            have = [i for i, b in enumerate(batch) if ci < len(b.jpegs)]
            if have:
                idx = (
                    index
                    if len(have) == n
                    else [rr.TimeColumn("frame", sequence=frames[have]), rr.TimeColumn("capture_time", duration=times[have])]
                )
                self.rows(
                    f"{path}/image", idx, np.ones(len(have), dtype=np.int64), rr.EncodedImage, blob=[batch[i].jpegs[ci] for i in have]
                )
            uv, depth, vis = self.visible(cam, both)
            o_vis = vis[:n_objs]
            half = np.maximum(cam.K[0, 0] * obj_radii[o_vis] / depth[:n_objs][o_vis], half_window)
            self.rows(
                f"{path}/objects",
                index,
                np.bincount(obj_frame[o_vis], minlength=n),
                rr.Boxes2D,
                centers=uv[:n_objs][o_vis],
                half_sizes=np.repeat(half[:, None], 2, axis=1),
                colors=obj_colours[o_vis],
            )
            self._camera_tracks(path, index, n, trk_frame, uv[n_objs:], vis[n_objs:], colours, trk_labels)

    def send_tracks(self, batch: list[Pending]) -> None:
        """Send again only the tracks of frames already sent (the world's and each camera's marks): tracks.csv's
        hindsight rows (TrackEstimate.before) joined them, and the later row at a time is the one the viewer shows."""
        n = len(batch)
        frames = np.array([b.index for b in batch], dtype=np.int64)
        index = [self.rr.TimeColumn("frame", sequence=frames), self.rr.TimeColumn("capture_time", duration=[b.time for b in batch])]
        tracks, n_trk, centres, colours = self._world_tracks(batch, index)
        trk_frame, trk_labels = np.repeat(np.arange(n), n_trk), [f"#{t.track_id}" for t in tracks]
        for cam in self.rig.cameras:
            uv, _, vis = self.visible(cam, centres)
            self._camera_tracks(f"world/cameras/{cam.name}", index, n, trk_frame, uv, vis, colours, trk_labels)

    def _world_tracks(self, batch: list[Pending], index: list[Any]) -> tuple[list, np.ndarray, np.ndarray, np.ndarray]:
        """Tracks: spheres of the ball's radius, 2-sigma covariance ellipsoids (one batched eigen-decomposition).
        Returns the batch's tracks, their count per frame, centres and packed colours."""
        rr = self.rr
        tracks = [t for b in batch for t in b.tracks]
        n_trk = np.array([len(b.tracks) for b in batch], dtype=np.int64)
        centres = np.array([t.position for t in tracks], dtype=float).reshape(-1, 3)
        radii = np.array([self.style.radius(t.target) for t in tracks], dtype=float)
        colours = np.array([self.style.packed(t.target) for t in tracks], dtype=np.uint32)
        labels = [f"#{t.track_id} {t.target}" for t in tracks]
        self.rows(
            "world/tracks",
            index,
            n_trk,
            rr.Ellipsoids3D,
            centers=centres,
            half_sizes=np.repeat(radii[:, None], 3, axis=1),
            colors=colours,
            labels=labels,
        )
        cov = np.array([t.covariance for t in tracks], dtype=float).reshape(-1, 3, 3)
        evals, evecs = np.linalg.eigh(0.5 * (cov + np.swapaxes(cov, 1, 2)))
        evecs[:, :, 2] *= np.sign(np.linalg.det(evecs))[:, None]  # proper rotations
        halves = 2.0 * np.sqrt(np.clip(evals, 0.0, None))
        self.rows(
            "world/tracks/covariance",
            index,
            n_trk,
            rr.Ellipsoids3D,
            centers=centres,
            half_sizes=halves,
            quaternions=quaternions_xyzw(evecs),
            colors=colours,
        )
        return tracks, n_trk, centres, colours

    def _camera_tracks(self, path, index, n, trk_frame, uv, vis, colours, trk_labels) -> None:
        """A camera's marks of the batch's tracks (``uv``, ``vis``: their projections, from ``visible``)."""
        self.rows(
            f"{path}/tracks",
            index,
            np.bincount(trk_frame[vis], minlength=n),
            self.rr.Points2D,
            positions=uv[vis],
            colors=colours[vis],
            labels=[lb for lb, v in zip(trk_labels, vis) if v],
        )

    def rows(self, path: str, index: list[Any], lengths: np.ndarray, archetype: type, **fields: Any) -> None:
        """One send_columns: each field's instances (all frames of the batch, concatenated) split into rows of these lengths.

        The component batches are built straight from the arrays (rerun's
        ``Archetype.columns`` would convert and partition each twice).
        """
        offsets = np.zeros(len(lengths) + 1, dtype=np.int32)
        np.cumsum(lengths, out=offsets[1:])
        columns = []
        for name, data in fields.items():
            key = (archetype, name)
            if key not in self._components:
                descriptor = getattr(archetype, f"descriptor_{name}")()
                self._components[key] = (descriptor, getattr(self.rr.components, descriptor.component_type.rsplit(".", 1)[-1] + "Batch"))
            descriptor, batch = self._components[key]
            columns.append(self.rr.ComponentColumn(descriptor, batch(data), offsets=offsets))
        self.rec.send_columns(path, index, columns)

    def segments(self, ends: np.ndarray) -> Any:
        """S x 2 x 3 segment end points -> rerun's LineStrip3D arrow array in one go (its converter loops per strip)."""
        import pyarrow as pa

        strip_type = self.rr.components.LineStrip3DBatch._ARROW_DATATYPE
        points = pa.FixedSizeListArray.from_arrays(
            pa.array(np.ascontiguousarray(ends, dtype=np.float32).reshape(-1)), type=strip_type.value_type
        )
        return pa.ListArray.from_arrays(pa.array(np.arange(0, 2 * len(ends) + 1, 2, dtype=np.int32)), points, type=strip_type)

    @staticmethod
    def visible(cam, points: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Pixels, depths, and whether each point is in front of the camera and inside its image."""
        pc = cam.to_camera(points)
        depth = pc[:, 2]
        front = depth > 1e-9
        uv = cam.distort_normalised(pc[:, :2] / np.where(front, depth, 1.0)[:, None])
        inside = front & cam.in_image(uv)
        return uv, depth, inside
