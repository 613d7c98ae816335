"""The calibration report: per-camera and stereo RMS, epipolar error, per-view errors, coverage, and a verdict."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from ..camera import Rig
from ..files import dump_yaml, write_text_atomic
from .boards import Board, board_to_dict
from .measures import CalibrationOptions, Intrinsics, _angle_deg, _common, _reprojection, epipolar_errors
from .views import RECOMMENDED_VIEWS, ViewSet, coverage


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


def _report(
    views: ViewSet, board: Board, dets, rig: Rig, intr: dict[int, Intrinsics], pairs: list[dict], options: CalibrationOptions
) -> dict[str, Any]:
    per_view: dict[int, dict[str, float]] = {v: {} for v in range(views.n_views)}
    cameras: dict[str, Any] = {}
    all_sq = []
    for c, cam in enumerate(rig.cameras):
        sq = []
        for v in intr[c].views:
            e = _reprojection(board, dets[v][c], cam.K, cam.dist)
            per_view[v][cam.name] = round(float(np.sqrt(np.mean(e**2))), 4)
            sq.append(e**2)
        sq = np.concatenate(sq)
        all_sq.append(sq)
        cov = coverage([dets[v][c].corners for v in intr[c].views], cam.image_size)
        cameras[cam.name] = {
            "rms_px": round(float(np.sqrt(sq.mean())), 4),
            "views": len(intr[c].views),
            "coverage": round(cov, 3),
            "fx": round(float(cam.K[0, 0]), 3),
            "fy": round(float(cam.K[1, 1]), 3),
            "fx_std": round(intr[c].std_f, 3),
            "cx": round(float(cam.K[0, 2]), 3),
            "cy": round(float(cam.K[1, 2]), 3),
            "dist": [round(float(x), 6) for x in cam.dist],
            "image_size": list(cam.image_size),
        }
    pair_reports = []
    epi_all = []
    for pr in pairs:
        ci, cj = rig.cameras[pr["p"]], rig.cameras[pr["c"]]
        epi = []
        for v, err in zip(pr["views"], pr["per_view"]):
            a, b = _common(dets[v][pr["p"]], dets[v][pr["c"]])
            epi.append(epipolar_errors(ci, cj, a.corners, b.corners))
            per_view[v][f"stereo {ci.name}-{cj.name}"] = round(float(err), 4)
        epi = np.concatenate(epi)
        epi_all.append(epi)
        R = cj.R @ ci.R.T
        baseline = float(np.linalg.norm(ci.centre - cj.centre))
        pair_reports.append(
            {
                "cameras": [ci.name, cj.name],
                "views": len(pr["views"]),
                "rms_px": round(pr["rms"], 4),
                "epipolar_mean_px": round(float(epi.mean()), 4),
                "epipolar_rms_px": round(float(np.sqrt(np.mean(epi**2))), 4),
                "baseline_m": round(baseline, 5),
                "baseline_squares": round(baseline / board.square, 4),
                "rotation_deg": round(_angle_deg(R), 3),
                "relabelled_views": pr["relabelled"],
            }
        )
    scores = {v: max(errs.values()) for v, errs in per_view.items() if errs}
    median = float(np.median(list(scores.values())))
    ranked = sorted(scores, key=lambda v: -scores[v])
    epi_all = np.concatenate(epi_all)
    report: dict[str, Any] = {
        "board": board_to_dict(board),
        "cameras": cameras,
        "pairs": pair_reports,
        "rms_px": round(float(np.sqrt(np.concatenate(all_sq).mean())), 4),
        "epipolar_mean_px": round(float(epi_all.mean()), 4),
        "epipolar_rms_px": round(float(np.sqrt(np.mean(epi_all**2))), 4),
        "world": rig.world if options.world_view is None else f"custom (board in view {options.world_view}, z up)",
        "views": {
            "used": views.n_views,
            "ranked": [
                {
                    "view": views.view_names[v],
                    "error_px": round(scores[v], 4),
                    "outlier": bool(scores[v] > max(2.5 * median, median + 0.25)),
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
            f"baseline {1000 * p['baseline_m']:.1f} mm ({p['baseline_squares']:.2f} squares), rotation {p['rotation_deg']:.2f} deg"
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


def save_report(report: dict[str, Any], path: str | Path) -> None:
    write_text_atomic(path, dump_yaml(report, width=120))  # view names such as '08' stay strings for any YAML reader


def report_path(calib_path: str | Path) -> Path:
    """calib/rig.yaml -> calib/rig.report.yaml"""
    p = Path(calib_path)
    return p.with_name(p.stem + ".report.yaml")
