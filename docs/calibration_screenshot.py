"""Screenshot of the rerun web viewer during a calibration, taken with headless Chromium.

Starts rerun's gRPC server with its web viewer (``rerun --serve-web``), runs
``stereotrack calibrate`` on OpenCV's 13 real stereo pairs (tests/data) with
``--connect`` to it, then photographs the web viewer as ``docs/viewer_screenshot.py``
does (the same helpers: a wrapper page that holds Chromium's screenshot until
the viewer has drawn).

    .venv/bin/python docs/calibration_screenshot.py [--out docs/calibration_viewer.png] [--wait 60]
"""

from __future__ import annotations

import argparse
import subprocess
import sys
import tempfile
from pathlib import Path
from urllib.parse import quote

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(Path(__file__).parent))

from viewer_screenshot import free_port, wrapper_server  # noqa: E402

from stereotrack.calibration.boards import Board, save_board  # noqa: E402
from stereotrack.sinks.viewer.process import _start_viewer_process, _wait_for_port  # noqa: E402

REAL = ROOT / "tests" / "data" / "opencv-stereo-chessboard"


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--out", default=str(Path(__file__).parent / "calibration_viewer.png"))
    ap.add_argument("--wait", type=float, default=60.0, help="seconds the viewer gets to load and draw")
    ap.add_argument("--size", default="1600,1000")
    args = ap.parse_args()

    work = Path(tempfile.mkdtemp(prefix="calib-shot-"))
    save_board(Board("chessboard", (10, 7), 0.03), work / "board.yaml")  # the Caltech/OpenCV board: 9x6 inner corners, 30 mm
    grpc_port, web_port = free_port(), free_port()
    server = _start_viewer_process(
        ["--serve-web", "--port", str(grpc_port), "--web-viewer-port", str(web_port)], "127.0.0.1", grpc_port, "the web viewer", False
    )
    try:
        _wait_for_port("127.0.0.1", web_port, server, 15.0)
        calib = subprocess.run(
            [
                sys.executable, "-m", "stereotrack", "calibrate", "--board", str(work / "board.yaml"),
                "--images", str(REAL / "left*.jpg"), str(REAL / "right*.jpg"), "--names", "left", "right",
                "--out", str(work / "rig.yaml"), "--connect", f"127.0.0.1:{grpc_port}", "--no-progress",
            ],
            capture_output=True, text=True, cwd=ROOT, timeout=600,
        )  # fmt: skip
        print(calib.stdout, calib.stderr, file=sys.stderr)
        if calib.returncode != 0:
            return calib.returncode
        grpc = quote(f"rerun+http://127.0.0.1:{grpc_port}/proxy", safe="")
        wrapper, port = wrapper_server(f"http://127.0.0.1:{web_port}/?url={grpc}", args.wait)
        profile = tempfile.mkdtemp(prefix="chromium-")
        cmd = [
            "chromium", "--headless", "--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
            "--disable-background-networking", "--disable-component-update", "--disable-sync",
            "--enable-unsafe-swiftshader", "--use-angle=swiftshader", f"--user-data-dir={profile}",
            f"--screenshot={Path(args.out).resolve()}", f"--window-size={args.size}", "--virtual-time-budget=5000",
            f"http://127.0.0.1:{port}/",
        ]  # fmt: skip
        shot = subprocess.run(cmd, capture_output=True, text=True, timeout=args.wait + 600)
        wrapper.shutdown()
        print(shot.stdout.strip() or shot.stderr.strip().splitlines()[-1], file=sys.stderr)
        return shot.returncode
    finally:
        server.terminate()
        server.wait(10)


if __name__ == "__main__":
    sys.exit(main())
