"""The calibration report: residuals after the fit per camera, pair and view, baselines with their uncertainty, coverage, a verdict."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import cv2
import numpy as np

from ..camera import Rig
from ..files import dump_yaml, write_text_atomic
from .boards import Board, board_to_dict
from .bundle import CX, CY, FX, BundleResult
from .measures import CalibrationOptions, Intrinsics, ViewFit, _angle_deg, _common, epipolar_errors
from .views import RECOMMENDED_VIEWS, ViewSet, coverage, coverage_grid


def _verdict(report: dict[str, Any]) -> tuple[str, list[str]]:
    redo, usable = [], []
    for name, cam in report["cameras"].items():
        if cam["rms_px"] > 1.0:
            redo.append(
                f"{name}: reprojection error {cam['rms_px']:.2f} px is high (blurred or moving board, board not flat, or wrong board settings)"
            )
        elif cam["rms_px"] > 0.5:
            usable.append(f"{name}: reprojection error {cam['rms_px']:.2f} px (under 0.5 px is good)")
        if cam["coverage"] < 0.35:
            redo.append(
                f"{name}: board corners cover only {100 * cam['coverage']:.0f}% of the image: move the board into the corners and edges"
            )
        elif cam["coverage"] < 0.6:
            usable.append(
                f"{name}: board corners cover {100 * cam['coverage']:.0f}% of the image (60% or more is good): add views near the edges"
            )
    for pair in report["pairs"]:
        label = "-".join(pair["cameras"])
        if pair["epipolar_mean_px"] > 1.0:
            redo.append(
                f"{label}: epipolar error {pair['epipolar_mean_px']:.2f} px is high (unsynchronised pairs, or the rig moved while capturing)"
            )
        elif pair["epipolar_mean_px"] > 0.5:
            usable.append(f"{label}: epipolar error {pair['epipolar_mean_px']:.2f} px (under 0.5 px is good)")
        if pair["views"] < 10:
            usable.append(f"{label}: only {pair['views']} views seen by both cameras ({RECOMMENDED_VIEWS}-25 give steadier results)")
    outliers = [w for w in report["views"]["ranked"] if w["outlier"]]
    if outliers:
        usable.append(
            f"{len(outliers)} view(s) fit much worse than the rest ({', '.join(w['view'] for w in outliers[:3])}): "
            f"try --drop-worst {len(outliers)}"
        )
    verdict = "redo" if redo else "usable" if usable else "good"
    return verdict, redo + usable


def _report(views: ViewSet, board: Board, fit: ViewFit, rig: Rig, bundle_fit: BundleResult, intr: dict[int, Intrinsics], relabelled: int,
            options: CalibrationOptions) -> dict[str, Any]:  # fmt: skip
    """Residuals after the fit (per camera, pair and view), coverage, baselines with their uncertainty, and a verdict."""
    per_view: dict[int, dict[str, float]] = {v: {} for v in range(views.n_views)}
    cameras: dict[str, Any] = {}
    all_sq = []
    joint = bundle_fit.covariance is not None
    for c, cam in enumerate(rig.cameras):
        seen = views.seen_by(c)
        sq = []
        for v in seen:
            e2 = np.sum(fit.residuals(v, c) ** 2, axis=1)
            per_view[v][cam.name] = round(float(np.sqrt(e2.mean())), 4)
            sq.append(e2)
        sq = np.concatenate(sq)
        all_sq.append(sq)
        corners = [fit.detections[v][c].corners for v in seen]
        fx_sd = bundle_fit.sd_intrinsic(c, FX) if joint else intr[c].std_f
        cameras[cam.name] = {
            "rms_px": round(float(np.sqrt(sq.mean())), 4),
            "views": len(seen),
            "coverage": round(coverage(corners, cam.image_size), 3),
            "coverage_grid": coverage_grid(corners, cam.image_size).tolist(),  # corners per cell of an 8-wide grid, top row first
            "fx": round(float(cam.K[0, 0]), 3),
            "fy": round(float(cam.K[1, 1]), 3),
            "fx_std": round(fx_sd, 3),
            "cx": round(float(cam.K[0, 2]), 3),
            "cy": round(float(cam.K[1, 2]), 3),
            "centre_std": round(max(bundle_fit.sd_intrinsic(c, CX), bundle_fit.sd_intrinsic(c, CY)), 3) if joint else None,
            "dist": [round(float(x), 6) for x in cam.dist],
            "image_size": list(cam.image_size),
        }
    pair_reports = []
    epi_all = []
    n_cams = len(rig.cameras)
    for i in range(n_cams):
        for j in range(i + 1, n_cams):
            pair = _pair_report(views, board, fit, rig, bundle_fit, i, j, per_view)
            if pair is not None:
                epi_all.append(pair.pop("epipolar"))
                pair_reports.append(pair)
    scores = {v: max(errs.values()) for v, errs in per_view.items() if errs}
    median = float(np.median(list(scores.values())))
    ranked = sorted(scores, key=lambda v: -scores[v])
    epi_all = np.concatenate(epi_all)
    report: dict[str, Any] = {
        "board": board_to_dict(board),
        "method": "joint" if joint else "pairwise",
        "cameras": cameras,
        "pairs": pair_reports,
        "rms_px": round(float(np.sqrt(np.concatenate(all_sq).mean())), 4),
        "epipolar_mean_px": round(float(epi_all.mean()), 4),
        "epipolar_rms_px": round(float(np.sqrt(np.mean(epi_all**2))), 4),
        "world": rig.world if options.world_view is None else f"custom (board in view {options.world_view}, z up)",
        "views": {
            "used": views.n_views,
            "relabelled": relabelled,  # chessboard detections numbered from the other end, turned to agree
            "ranked": [
                {
                    "view": views.view_names[v],
                    "error_px": round(scores[v], 4),
                    "outlier": bool(
                        scores[v] > max(3 * median, median + 0.3)
                    ),  # one board pose per view for every camera: a wider margin than per-camera fits
                }
                for v in ranked
            ],
            "per_view_rms_px": {views.view_names[v]: per_view[v] for v in range(views.n_views)},
        },
    }
    verdict, reasons = _verdict(report)
    report["verdict"] = verdict
    report["reasons"] = reasons
    return report


def _pair_report(views: ViewSet, board: Board, fit: ViewFit, rig: Rig, bundle_fit: BundleResult, i: int, j: int,
                 per_view: dict[int, dict[str, float]]) -> dict[str, Any] | None:  # fmt: skip
    """One pair of cameras over the views both saw: residuals, epipolar error, baseline and rotation; None if they share none."""
    ci, cj = rig.cameras[i], rig.cameras[j]
    shared, epi, sq = [], [], []
    for v in range(views.n_views):
        a, b = fit.detections[v][i], fit.detections[v][j]
        common = _common(a, b) if a is not None and b is not None else None
        if common is None:
            continue
        shared.append(v)
        epi.append(epipolar_errors(ci, cj, common[0].corners, common[1].corners))
        e2 = np.concatenate([np.sum(fit.residuals(v, i) ** 2, axis=1), np.sum(fit.residuals(v, j) ** 2, axis=1)])
        per_view[v][f"stereo {ci.name}-{cj.name}"] = round(float(np.sqrt(e2.mean())), 4)
        sq.append(e2)
    if not shared:
        return None
    epi = np.concatenate(epi)
    baseline = float(np.linalg.norm(ci.centre - cj.centre))
    out = {
        "cameras": [ci.name, cj.name],
        "views": len(shared),
        "rms_px": round(float(np.sqrt(np.concatenate(sq).mean())), 4),
        "epipolar_mean_px": round(float(epi.mean()), 4),
        "epipolar_rms_px": round(float(np.sqrt(np.mean(epi**2))), 4),
        "baseline_m": round(baseline, 6),
        "baseline_squares": round(baseline / board.square, 4),
        "rotation_deg": round(_angle_deg(cj.R @ ci.R.T), 3),
        "epipolar": epi,
    }
    if bundle_fit.covariance is not None:  # in the fit's own frame (camera 0's): the baseline does not depend on the world chosen

        def length(cam_poses: np.ndarray) -> float:
            centres = [-cv2.Rodrigues(p[:3])[0].T @ p[3:] for p in cam_poses[[i, j]]]
            return float(np.linalg.norm(centres[0] - centres[1]))

        sd = bundle_fit.sd_of(length)
        out["baseline_sd_m"] = round(sd, 7)
        out["baseline_sd_pct"] = round(100 * sd / baseline, 4)
    return out


def format_report(report: dict[str, Any]) -> str:
    """The report as a few readable lines for the console."""
    lines = []
    for name, cam in report["cameras"].items():
        lines.append(
            f"{name}: RMS {cam['rms_px']:.3f} px over {cam['views']} views, fx {cam['fx']:.1f} (+-{cam['fx_std']:.1f}) fy {cam['fy']:.1f}, "
            f"centre ({cam['cx']:.1f}, {cam['cy']:.1f}), coverage {100 * cam['coverage']:.0f}%"
        )
    for p in report["pairs"]:
        lines.append(
            f"{p['cameras'][0]}-{p['cameras'][1]}: stereo RMS {p['rms_px']:.3f} px over "
            f"{p['views']} views, epipolar error mean {p['epipolar_mean_px']:.3f} px, "
            f"baseline {1000 * p['baseline_m']:.1f}{_plus_minus(1000 * p.get('baseline_sd_m', 0.0))} mm ({p['baseline_squares']:.2f} squares), "
            f"rotation {p['rotation_deg']:.2f} deg"
        )
    worst = report["views"]["ranked"][:3]
    lines.append("worst views: " + ", ".join(f"{w['view']} {w['error_px']:.3f} px{' (outlier)' if w['outlier'] else ''}" for w in worst))
    if report["views"].get("dropped"):
        lines.append("dropped views: " + ", ".join(report["views"]["dropped"]))
    lines.append(f"world frame: {report['world']}")
    verdict = report["verdict"]
    lines.append(f"verdict: {verdict}" + (": " + "; ".join(report["reasons"]) if report["reasons"] else ""))
    if verdict == "redo":
        lines.append("what to do: see 'Calibrating two webcams' in the README (steady board, flat print, all of the image covered)")
    return "\n".join(lines)


def _plus_minus(sd: float) -> str:
    return f" +-{sd:.1f}" if sd >= 0.05 else f" +-{sd:.2f}" if sd > 0 else ""


def save_report(report: dict[str, Any], path: str | Path) -> None:
    write_text_atomic(path, dump_yaml(report, width=120))  # view names such as '08' stay strings for any YAML reader


def report_path(calib_path: str | Path) -> Path:
    """calib/rig.yaml -> calib/rig.report.yaml"""
    p = Path(calib_path)
    return p.with_name(p.stem + ".report.yaml")
