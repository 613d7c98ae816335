"""Screenshot of the rerun web viewer showing the demo, taken with headless Chromium.

Runs ``stereotrack demo --serve`` (the gRPC server + web viewer on localhost,
which keep serving after the run), opens the web viewer in headless Chromium
(Debian's ``chromium`` package; WebGL through SwiftShader, there is no GPU)
and writes the PNG. Headless Chromium's ``--screenshot`` fires soon after the
page's load event, before the viewer's WebAssembly has fetched and drawn the
data, so the viewer is shown in a full-window iframe of a small page whose
load event waits ``--wait`` seconds on a deliberately slow image.

    .venv/bin/python docs/viewer_screenshot.py [--out docs/viewer.png] [--workdir DIR] [--wait 45]
"""

from __future__ import annotations

import argparse
import http.server
import signal
import socket
import subprocess
import sys
import tempfile
import threading
import time
from pathlib import Path


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


def wrapper_server(viewer_url: str, wait: float) -> tuple[http.server.ThreadingHTTPServer, int]:
    page = (
        '<!doctype html><html><body style="margin:0;overflow:hidden">'
        f'<iframe src="{viewer_url}" style="border:0;width:100vw;height:100vh;display:block"></iframe>'
        '<img src="/slow" style="display:none"></body></html>'
    ).encode()

    class Handler(http.server.BaseHTTPRequestHandler):
        def do_GET(self) -> None:
            if self.path.startswith("/slow"):
                time.sleep(wait)
                body, ctype = b"GIF89a", "image/gif"
            else:
                body, ctype = page, "text/html"
            self.send_response(200)
            self.send_header("Content-Type", ctype)
            self.send_header("Content-Length", str(len(body)))
            self.end_headers()
            self.wfile.write(body)

        def log_message(self, *args) -> None:
            pass

    port = free_port()
    server = http.server.ThreadingHTTPServer(("127.0.0.1", port), Handler)
    threading.Thread(target=server.serve_forever, daemon=True).start()
    return server, port


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--out", default=str(Path(__file__).parent / "viewer.png"))
    ap.add_argument("--workdir", help="where the demo recording is rendered/reused (default: a temporary folder)")
    ap.add_argument("--wait", type=float, default=45.0, help="seconds the viewer gets to load and draw")
    ap.add_argument("--size", default="1600,1000")
    args = ap.parse_args()

    workdir = Path(args.workdir or tempfile.mkdtemp(prefix="viewer-shot-"))
    workdir.mkdir(parents=True, exist_ok=True)
    grpc_port, web_port = free_port(), free_port()
    demo = subprocess.Popen(
        [
            sys.executable,
            "-m",
            "stereotrack",
            "demo",
            "--serve",
            "--serve-port",
            str(grpc_port),
            "--web-port",
            str(web_port),
            "--rrd",
            "out/demo/demo.rrd",
            "--quiet",
        ],
        cwd=workdir,
        stderr=subprocess.PIPE,
        text=True,
        preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL),  # Ctrl-C works even when started from a background job
    )
    try:
        url = None
        for line in demo.stderr:
            sys.stderr.write(line)
            if "keeps serving at" in line:
                url = line.split("keeps serving at", 1)[1].split()[0]
                break
        if url is None:
            print("the demo ended without serving the viewer", file=sys.stderr)
            return 1
        server, port = wrapper_server(url, args.wait)
        profile = tempfile.mkdtemp(prefix="chromium-")
        cmd = [
            "chromium",
            "--headless",
            "--no-sandbox",
            "--disable-gpu",
            "--disable-quic",
            "--no-first-run",
            "--disable-background-networking",
            "--disable-component-update",
            "--disable-sync",
            "--enable-unsafe-swiftshader",
            "--use-angle=swiftshader",  # software WebGL2: rerun's wgpu falls back to GL
            f"--user-data-dir={profile}",
            f"--screenshot={Path(args.out).resolve()}",
            f"--window-size={args.size}",
            "--virtual-time-budget=5000",
            f"http://127.0.0.1:{port}/",
        ]
        shot = subprocess.run(cmd, capture_output=True, text=True, timeout=args.wait + 600)
        server.shutdown()
        print(shot.stdout.strip() or shot.stderr.strip().splitlines()[-1], file=sys.stderr)
        return shot.returncode
    finally:
        if demo.poll() is None:
            demo.send_signal(signal.SIGINT)  # ends the demo's serving; it prints its summary and exits
            try:
                demo.communicate(timeout=60)
            except subprocess.TimeoutExpired:
                demo.kill()


if __name__ == "__main__":
    sys.exit(main())
