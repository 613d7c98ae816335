"""What calibration saw, in the rerun viewer: ``calibrate --rrd FILE`` and the live calibration's viewer.

Timeline ``view`` (one step per view taken):

    views/<cam>/image        the camera's image of that view (JPEG)
    views/<cam>/detected     the board corners found (green), with their ids
    views/<cam>/reprojected  where the fitted model puts them (red), with each corner's residual_px
    views/<cam>/residuals    residual arrows from detected to fitted, magnified RESIDUAL_SCALE times
    stats/view_rms_px/<cam>  each view's RMS residual, per camera

Static (after the fit): the coverage heat-map per camera (``coverage/<cam>``),
the cameras and every board pose in 3D (``world/cameras/<cam>``,
``world/boards/<view>``) and the report (``report``). In live calibration
each view appears as it is taken; the fit follows when capture ends.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from ...calibration.annotate import RESIDUAL_SCALE, draw_coverage
from ...calibration.boards import Board
from ...calibration.report import format_report
from ...calibration.solve import Calibration
from ...calibration.views import ViewSet
from ...capture.signals import output_kept
from .process import finish_outlets, flush_bounded, open_outlets
from .sink import VizOutputs
from .style import APPLICATION_ID, PALETTE

DETECTED, FITTED, ARROW = (60, 200, 60), (230, 40, 40), (255, 220, 0)


class CalibrationViewer:
    """Logs calibration views and the fit to rerun; rerun is imported only when one is made."""

    def __init__(self, outputs: VizOutputs, board: Board, camera_names: Sequence[str], jpeg_quality: int = 85):
        import cv2
        import rerun as rr

        self.rr, self.cv2 = rr, cv2
        self.board = board
        self.outputs = outputs
        self._jpeg = [cv2.IMWRITE_JPEG_QUALITY, int(jpeg_quality)]
        self._at: dict[str, int] = {}  # view name -> its step on the view timeline (live: views come one at a time)
        self.rec = rr.RecordingStream(APPLICATION_ID)
        self.rec.set_log_time_enabled(False)
        self.rec.send_recording_name("calibration")
        self._closed = False
        # Refuses a missing viewer or a taken port before anything is written; the .rrd is written under a
        # temporary name and takes its own only when close() finishes a run that did not fail.
        self._outlets = open_outlets(rr, outputs)
        self.web_url = self._outlets.web_url
        self.rec.set_sinks(*self._outlets.sinks, default_blueprint=_blueprint(camera_names))

    # ----------------------------------------------------------------- as views are taken

    def log_views(self, views: ViewSet) -> None:
        """Log the views not logged yet: images and detected corners (live: called after each view taken)."""
        for v, name in enumerate(views.view_names):
            if name in self._at:
                continue
            self._at[name] = len(self._at)
            self.rec.set_time("view", sequence=self._at[name])
            for c, cam in enumerate(views.camera_names):
                d = views.detections[v][c]
                if views.images:
                    ok, jpeg = self.cv2.imencode(".jpg", views.images[v][c], self._jpeg)
                    self.rec.log(f"views/{cam}/image", self.rr.EncodedImage(contents=jpeg.tobytes(), media_type="image/jpeg"))
                if d is not None:
                    self.rec.log(
                        f"views/{cam}/detected",
                        self.rr.Points2D(d.corners, colors=DETECTED, radii=4.0, class_ids=d.ids),
                        self.rr.AnyValues(view_name=name),
                    )

    # ----------------------------------------------------------------- after the fit

    def log_fit(self, calibration: Calibration) -> None:
        """Log the fitted corners and residuals of every view, the coverage, the 3D scene and the report."""
        rr, rec = self.rr, self.rec
        views, fit = calibration.views, calibration.fit
        self.log_views(views)
        for v, name in enumerate(views.view_names):  # views dropped by --drop-worst keep their images, without a fit
            rec.set_time("view", sequence=self._at[name])
            for c, cam in enumerate(views.camera_names):
                d = fit.detections[v][c]
                if d is None:
                    continue
                e = fit.residuals(v, c)
                norm = np.linalg.norm(e, axis=1)
                rec.log(
                    f"views/{cam}/reprojected", rr.Points2D(fit.reprojected[v][c], colors=FITTED, radii=2.5), rr.AnyValues(residual_px=norm)
                )
                rec.log(f"views/{cam}/residuals", rr.Arrows2D(origins=d.corners, vectors=RESIDUAL_SCALE * e, colors=ARROW, radii=1.0))
                rec.log(f"stats/view_rms_px/{cam}", rr.Scalars(float(np.sqrt(np.mean(norm**2)))))
        for c, cam in enumerate(views.camera_names):
            seen = views.seen_by(c)
            corners = [fit.detections[v][c].corners for v in seen]
            background = views.images[seen[0]][c] if views.images and seen else None
            heat = draw_coverage(views.image_sizes[c], corners, background)
            rec.log(f"coverage/{cam}", rr.Image(heat[:, :, ::-1]), static=True)  # BGR -> RGB
        self._log_3d(calibration)
        text = format_report(calibration.report)
        rec.log("report", rr.TextDocument(f"```\n{text}\n```", media_type=rr.MediaType.MARKDOWN), static=True)

    def _log_3d(self, calibration: Calibration) -> None:
        rr, rec = self.rr, self.rec
        rig, fit, board = calibration.rig, calibration.fit, self.board
        rec.log("world", rr.ViewCoordinates.RDF if rig.world in rig.names else rr.ViewCoordinates.RIGHT_HAND_Z_UP, static=True)
        for cam in rig.cameras:
            path = f"world/cameras/{cam.name}"
            rec.log(path, rr.Transform3D(translation=cam.t, mat3x3=cam.R, relation=rr.TransformRelation.ChildFromParent), static=True)
            rec.log(path, rr.Pinhole(image_from_camera=cam.K, resolution=[cam.width, cam.height], image_plane_distance=0.1), static=True)
        w, h = board.size_m
        outline = np.array([[0, 0, 0], [w, 0, 0], [w, h, 0], [0, h, 0], [0, 0, 0]], float)
        for v, name in enumerate(calibration.views.view_names):
            colour = PALETTE[v % len(PALETTE)]
            path = f"world/boards/{name}"
            rec.log(path, rr.Transform3D(translation=fit.board_t[v], mat3x3=fit.board_R[v]), static=True)
            rec.log(
                path,
                rr.LineStrips3D([outline], colors=colour, radii=0.002),
                rr.Points3D(board.object_points(), colors=colour, radii=0.002),
                static=True,
            )

    def close(self) -> None:
        """Finish the log in bounded time; a served web viewer dies with us, a spawned window stays.
        A run that failed (not Ctrl-C) leaves the previous .rrd as it was."""
        if self._closed:
            return
        self._closed = True
        kept = output_kept()  # asked before flushing: an error the flush raises is not the run's
        try:
            flush_bounded(self.rec, self._outlets)
        finally:
            finish_outlets(self.rec, self._outlets, keep_rrd=kept)

    @property
    def rrd_path(self) -> Path | None:
        return Path(self.outputs.rrd) if self.outputs.rrd is not None else None

    def __enter__(self) -> CalibrationViewer:
        return self

    def __exit__(self, *exc: Any) -> None:
        self.close()


def _blueprint(camera_names: Sequence[str]) -> Any:
    """One column per camera (view with corners and residuals above its coverage), the 3D scene and the residuals per view."""
    import rerun.blueprint as rrb

    columns = [
        rrb.Vertical(
            rrb.Spatial2DView(origin=f"views/{cam}", name=f"{cam}: detected (green), fitted (red), residual x{RESIDUAL_SCALE:g}"),
            rrb.Spatial2DView(origin=f"coverage/{cam}", name=f"{cam}: coverage"),
            row_shares=[3, 2],
        )
        for cam in camera_names
    ]
    return rrb.Blueprint(
        rrb.Horizontal(
            *columns,
            rrb.Vertical(
                rrb.Spatial3DView(origin="world", name="cameras and board poses"),
                rrb.TimeSeriesView(origin="stats/view_rms_px", name="RMS per view, px"),
                rrb.TextDocumentView(origin="report", name="report"),
                row_shares=[3, 2, 2],
            ),
        ),
        collapse_panels=True,
    )
