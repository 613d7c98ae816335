"""Viewer processes and addresses: the rerun executable, spawned or served viewers, --connect URLs."""

from __future__ import annotations

import shutil
import socket
import subprocess
import sys
import time
from pathlib import Path

from ...console import info
from ...errors import StereotrackError


def rerun_executable() -> str:
    """The rerun CLI shipped with rerun-sdk (the ``rerun_cli`` package), else the one on PATH."""
    import importlib.util

    spec = importlib.util.find_spec("rerun_cli")
    if spec and spec.submodule_search_locations:
        exe = Path(list(spec.submodule_search_locations)[0]) / "rerun"
        if exe.is_file():
            return str(exe)
    found = shutil.which("rerun") or shutil.which("rerun", path=str(Path(sys.executable).parent))
    if not found:
        raise StereotrackError("the rerun viewer executable is missing; reinstall with 'pip install rerun-sdk'")
    return found


def _wait_for_port(host: str, port: int, proc: subprocess.Popen, seconds: float) -> bool:
    host = "127.0.0.1" if host in ("0.0.0.0", "::", "") else host
    deadline = time.monotonic() + seconds
    while time.monotonic() < deadline:
        if proc.poll() is not None:
            return False
        try:
            with socket.create_connection((host, port), timeout=0.2):
                return True
        except OSError:
            time.sleep(0.1)
    return False


def _die_with_parent() -> None:
    """In the child before exec: get SIGTERM when the parent dies, even by SIGKILL (Linux only)."""
    import ctypes
    import signal

    try:
        ctypes.CDLL(None, use_errno=True).prctl(1, int(signal.SIGTERM))  # PR_SET_PDEATHSIG
    except (OSError, AttributeError):
        pass


def _start_viewer_process(args: list[str], host: str, port: int, what: str, detach: bool) -> subprocess.Popen:
    """Start the rerun CLI in its own session (a terminal's Ctrl-C goes to us, not to it).

    A detached viewer (a window the user looks at) outlives us; a server we host dies with us.
    """
    proc = subprocess.Popen(
        [rerun_executable(), *args],
        stdin=subprocess.DEVNULL,
        stdout=subprocess.DEVNULL,
        stderr=subprocess.PIPE if not detach else subprocess.DEVNULL,
        start_new_session=True,
        preexec_fn=None if detach or not sys.platform.startswith("linux") else _die_with_parent,
    )
    if not _wait_for_port(host, port, proc, 15.0):
        err = ""
        if proc.poll() is None:
            proc.terminate()
        elif proc.stderr is not None:
            lines = [ln for ln in proc.stderr.read().decode(errors="replace").splitlines() if ln.strip()]
            err = f" ({lines[-1].strip()[:200]})" if lines else ""
        raise StereotrackError(
            f"could not start {what} on port {port}{err}; is the port taken? use --rrd FILE and open it later with 'rerun FILE'"
        )
    return proc


def normalise_connect_url(url: str) -> str:
    """Accept rerun+http://HOST:PORT/proxy as is; HOST:PORT or PORT are expanded to it."""
    url = url.strip()
    if "://" not in url:
        host, _, port = url.rpartition(":")
        if not port.isdigit():
            raise StereotrackError(f"--connect {url!r}: expected rerun+http://HOST:PORT/proxy, HOST:PORT or PORT")
        return f"rerun+http://{host or '127.0.0.1'}:{port}/proxy"
    scheme = url.split("://", 1)[0]
    if scheme not in ("rerun", "rerun+http", "rerun+https") or not url.rstrip("/").endswith("/proxy"):
        raise StereotrackError(
            f"--connect {url!r}: expected rerun+http://HOST:PORT/proxy (scheme rerun, rerun+http or rerun+https, path /proxy)"
        )
    return url


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


def open_outputs(rr, out) -> tuple[list, list[subprocess.Popen], str | None]:
    """rerun sinks for a ``VizOutputs`` (file, spawned viewer, remote viewer, served web viewer):
    (sinks, child processes started, the web viewer's URL if served)."""
    sinks: list = []
    children: list[subprocess.Popen] = []
    web_url = None
    if out.rrd is not None:
        path = Path(out.rrd)
        if path.is_dir():
            raise StereotrackError(f"--rrd {path}: is a folder; give a file name such as {path / 'run.rrd'}")
        path.parent.mkdir(parents=True, exist_ok=True)
        sinks.append(rr.FileSink(str(path)))
    if out.connect:
        sinks.append(rr.GrpcSink(normalise_connect_url(out.connect)))
    if out.spawn:
        port = _free_port()
        children.append(
            _start_viewer_process(
                ["--port", str(port), "--hide-welcome-screen"], "127.0.0.1", port, "the rerun viewer (needs a display)", True
            )
        )
        sinks.append(rr.GrpcSink(f"rerun+http://127.0.0.1:{port}/proxy"))
    if out.serve:
        proc = _start_viewer_process(
            ["--serve-web", "--bind", out.bind, "--port", str(out.grpc_port), "--web-viewer-port", str(out.web_port)],
            out.bind,
            out.grpc_port,
            "the web viewer server",
            False,
        )
        children.append(proc)
        _wait_for_port(out.bind, out.web_port, proc, 10.0)
        host = "127.0.0.1" if out.bind in ("0.0.0.0", "::") else out.bind
        sinks.append(rr.GrpcSink(f"rerun+http://{host}:{out.grpc_port}/proxy"))
        from urllib.parse import quote

        web_url = f"http://{host}:{out.web_port}/?url={quote(f'rerun+http://{host}:{out.grpc_port}/proxy', safe='')}"
        info(f"web viewer: {web_url}")
    return sinks, children, web_url
