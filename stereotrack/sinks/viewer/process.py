"""Viewer processes and addresses: the rerun executable, spawned or served viewers, --connect URLs."""

from __future__ import annotations

import errno
import ipaddress
import os
import shutil
import socket
import subprocess
import sys
import threading
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from ...errors import StereotrackError
from ...files import AtomicOutput


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


def _die_with_parent() -> None:
    """In the child before exec: get SIGTERM when the parent dies, even by SIGKILL (Linux only)."""
    import ctypes
    import signal

    try:
        ctypes.CDLL(None, use_errno=True).prctl(1, int(signal.SIGTERM))  # PR_SET_PDEATHSIG
    except (OSError, AttributeError):
        pass


def child_env() -> dict[str, str]:
    """The environment for a rerun CLI we start: without the RUST_LOG=off we set for our own process only
    (the child's last stderr line is the reason it gives when it cannot start)."""
    env = dict(os.environ)
    if env.get("RUST_LOG") == "off" and os.environ.get("STEREOTRACK_SET_RUST_LOG"):
        env.pop("RUST_LOG")
    env.pop("STEREOTRACK_SET_RUST_LOG", None)
    return env


def _start_viewer_process(args: list[str], host: str, ports: list[int], what: str, detach: bool) -> subprocess.Popen:
    """Start the rerun CLI in its own session (a terminal's Ctrl-C goes to us, not to it) and wait until it
    serves on ``ports`` itself: data goes only to our own viewer, never to another program on that port.

    A detached viewer (a window the user looks at) outlives us; a server we host dies with us.
    """
    proc = subprocess.Popen(
        [rerun_executable(), *args],
        stdin=subprocess.DEVNULL,
        stdout=subprocess.DEVNULL,
        stderr=subprocess.PIPE if not detach else subprocess.DEVNULL,
        start_new_session=True,
        preexec_fn=None if detach or not sys.platform.startswith("linux") else _die_with_parent,
        env=child_env(),
    )
    deadline = time.monotonic() + 15.0
    for port in ports:
        if not _wait_until_serving(proc, host, port, deadline):
            err = ""
            if proc.poll() is None:
                proc.kill()
                proc.wait()
            if proc.stderr is not None:
                lines = [ln for ln in proc.stderr.read().decode(errors="replace").splitlines() if ln.strip()]
                err = f" ({_strip_ansi(lines[-1]).strip()[:200]})" if lines else ""
            raise StereotrackError(f"could not start {what} on port {port}{err}; use --rrd FILE and open it later with 'rerun FILE'")
    return proc


def _strip_ansi(text: str) -> str:
    import re

    return re.sub(r"\x1b\[[0-9;]*[A-Za-z]", "", text)


def _wait_until_serving(proc: subprocess.Popen, host: str, port: int, deadline: float) -> bool:
    """True once ``proc`` listens on ``port``: its own socket where /proc tells (Linux), else any that answers."""
    host = "127.0.0.1" if host in ("0.0.0.0", "::", "") else host
    while time.monotonic() < deadline:
        if proc.poll() is not None:
            return False
        owned = _listens(proc.pid, port)
        if owned:
            return True
        if owned is None:
            try:
                with socket.create_connection((host, port), timeout=0.2):
                    return True
            except OSError:
                pass
        time.sleep(0.1)
    return False


def _listens(pid: int, port: int) -> bool | None:
    """Whether process ``pid`` holds a listening TCP socket on ``port``; None where /proc cannot tell."""
    inodes = set()
    found = False
    for table in ("/proc/net/tcp", "/proc/net/tcp6"):
        try:
            with open(table) as f:
                rows = f.read().splitlines()[1:]
        except OSError:
            continue
        found = True
        for row in rows:
            cols = row.split()
            if len(cols) > 9 and cols[3] == "0A" and int(cols[1].rsplit(":", 1)[1], 16) == port:  # 0A: LISTEN
                inodes.add(cols[9])
    if not found:
        return None
    try:
        fds = os.listdir(f"/proc/{pid}/fd")
    except OSError:
        return None
    for fd in fds:
        try:
            link = os.readlink(f"/proc/{pid}/fd/{fd}")
        except OSError:
            continue
        if link.startswith("socket:[") and link[8:-1] in inodes:
            return True
    return False


def check_serve_address(bind: str, ports: list[tuple[str, int]]) -> None:
    """--serve: the address must be one of this machine's and every port free, checked before anything starts."""
    try:
        family = socket.AF_INET6 if ipaddress.ip_address(bind).version == 6 else socket.AF_INET
    except ValueError:
        raise StereotrackError(
            f"--bind {bind!r}: expected an IP address such as 127.0.0.1 (this machine only) or 0.0.0.0 (every interface)"
        ) from None
    if len({p for _, p in ports}) != len(ports):
        raise StereotrackError(f"{' and '.join(f for f, _ in ports)} must differ, got {ports[0][1]} for both")
    for flag, port in ports:
        with socket.socket(family, socket.SOCK_STREAM) as s:
            s.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)  # a port in TIME_WAIT is free; one with a listener is not
            try:
                s.bind((bind, port))
            except OSError as exc:
                if exc.errno == errno.EADDRINUSE:
                    raise StereotrackError(
                        f"{flag} {port}: another program listens on that port; choose another port with {flag}"
                    ) from None
                if exc.errno == errno.EADDRNOTAVAIL:
                    raise StereotrackError(f"--bind {bind}: not an address of this machine") from None
                raise StereotrackError(f"{flag} {port}: cannot listen on {bind}:{port} ({exc.strerror})") from None


def check_viewer_listens(url: str, seconds: float = 3.0) -> None:
    """--connect: a viewer must accept connections at the URL, checked up front (rerun would wait for it at exit)."""
    from urllib.parse import urlsplit

    try:
        parts = urlsplit(url)
        host, port = parts.hostname, parts.port or 9876
    except ValueError:
        raise StereotrackError(f"--connect {url}: expected rerun+http://HOST:PORT/proxy with a port from 1 to 65535") from None
    if not host:
        raise StereotrackError(f"--connect {url}: expected rerun+http://HOST:PORT/proxy")
    outcome: dict[str, BaseException | bool] = {}

    def attempt() -> None:
        try:
            with socket.create_connection((host, port), timeout=seconds) as conn:
                outcome["ok"] = parts.scheme == "rerun+https" or _speaks_http2(conn)
        except OSError as exc:
            outcome["error"] = exc

    probe = threading.Thread(target=attempt, daemon=True)  # a name lookup has no timeout of its own
    probe.start()
    probe.join(seconds + 0.5)
    if outcome.get("ok"):
        return
    error = outcome.get("error")
    if outcome.get("ok") is False:
        raise StereotrackError(
            f"--connect {url}: the program listening at {host}:{port} is not a rerun viewer (no gRPC answer); check the port"
        )
    if isinstance(error, socket.gaierror):
        reason = f"cannot find the host {host!r}"
    elif isinstance(error, ConnectionRefusedError):
        reason = f"no viewer listens at {host}:{port}"
    else:
        reason = f"no answer from {host}:{port} within {seconds:g} s"
    raise StereotrackError(f"--connect {url}: {reason}; start the viewer first ('rerun' listens on 9876) or save with --rrd FILE")


def _speaks_http2(conn: socket.socket) -> bool:
    """A gRPC server answers the HTTP/2 connection preface with a SETTINGS frame; another program does not
    (and rerun would wait on it for ever when it disconnects)."""
    conn.settimeout(2.0)
    conn.sendall(b"PRI * HTTP/2.0\r\n\r\nSM\r\n\r\n" + bytes.fromhex("000000040000000000"))
    head = b""
    try:
        while len(head) < 9:
            chunk = conn.recv(9 - len(head))
            if not chunk:
                break
            head += chunk
    except OSError:
        return False
    return len(head) == 9 and head[3] == 0x04  # frame type 4: SETTINGS


def reachable_host(bind: str) -> str:
    """The host name to give a browser for a server bound to ``bind``: this machine's address for 0.0.0.0."""
    if bind not in ("0.0.0.0", "::"):
        return bind
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as s:
        try:
            s.connect(("192.0.2.1", 9))  # a documentation address: a UDP connect sends nothing, it only picks the route
            return s.getsockname()[0]
        except OSError:
            return socket.gethostname()


def normalise_connect_url(url: str) -> str:
    """Accept rerun+http://HOST:PORT/proxy as is; HOST:PORT or PORT are expanded to it."""
    url = url.strip()
    if any(c.isspace() or not c.isprintable() for c in url):
        raise StereotrackError(f"--connect {url!r}: expected rerun+http://HOST:PORT/proxy, HOST:PORT or PORT")
    if "://" not in url:
        host, _, port = url.rpartition(":")
        if not port.isdigit() or not 0 < int(port) < 65536:
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


# --------------------------------------------------------------------------- where the log goes, opened and finished

FLUSH_SECONDS = 2.0  # at the end, a viewer gets this long to take what is left (rerun's disconnect adds up to 5 s)


@dataclass
class Outlets:
    """The rerun sinks of a run and what stands behind them: our viewer processes, the .rrd being written."""

    sinks: list[Any] = field(default_factory=list)
    children: list[subprocess.Popen] = field(default_factory=list)
    rrd: AtomicOutput | None = None
    web_url: str | None = None
    watched: bool = False  # a viewer takes the data as it comes (not only a file)


def open_outlets(rr: Any, out: Any) -> Outlets:
    """Open what ``out`` (a VizOutputs) asks for. A viewer that is not there, a port another program holds
    or an address that is not this machine's is refused here, before anything is written."""
    outlets = Outlets(watched=bool(out.spawn or out.connect or out.serve))
    if out.connect:
        url = normalise_connect_url(out.connect)
        check_viewer_listens(url)
        outlets.sinks.append(rr.GrpcSink(url))
    if out.serve:
        check_serve_address(out.bind, [("--serve-port", out.grpc_port), ("--web-port", out.web_port)])
    if out.rrd is not None:
        outlets.rrd = AtomicOutput(out.rrd, "--rrd")
        outlets.rrd.open("wb").close()  # the folder exists and the name is ours; rerun writes the file itself
        outlets.sinks.append(rr.FileSink(str(outlets.rrd.temp)))
    try:
        if out.spawn:
            port = _free_port()
            outlets.children.append(
                _start_viewer_process(
                    ["--port", str(port), "--hide-welcome-screen"], "127.0.0.1", [port], "the rerun viewer (needs a display)", True
                )
            )
            outlets.sinks.append(rr.GrpcSink(f"rerun+http://127.0.0.1:{port}/proxy"))
        if out.serve:
            args = ["--serve-web", "--bind", out.bind, "--port", str(out.grpc_port), "--web-viewer-port", str(out.web_port)]
            outlets.children.append(_start_viewer_process(args, out.bind, [out.grpc_port, out.web_port], "the web viewer server", False))
            local = "127.0.0.1" if out.bind in ("0.0.0.0", "::") else out.bind
            outlets.sinks.append(rr.GrpcSink(f"rerun+http://{local}:{out.grpc_port}/proxy"))
            from urllib.parse import quote

            host = reachable_host(out.bind)
            outlets.web_url = f"http://{host}:{out.web_port}/?url={quote(f'rerun+http://{host}:{out.grpc_port}/proxy', safe='')}"
    except BaseException:
        if outlets.rrd is not None:
            outlets.rrd.abort()
        stop_children(outlets.children)
        raise
    return outlets


def flush_bounded(rec: Any, outlets: Outlets) -> None:
    """Flush the log; a viewer that does not take it within FLUSH_SECONDS is given up on with one warning."""
    try:
        rec.flush(timeout_sec=FLUSH_SECONDS if outlets.watched else 60.0)
    except Exception as exc:  # rerun: "Flush timed out", "gRPC connection severed", ...
        from ...console import warn

        warn(f"the viewer did not take the end of the log ({str(exc).splitlines()[0][:120]}); the run's other outputs are complete")


def finish_outlets(rec: Any, outlets: Outlets, keep_rrd: bool) -> None:
    """Close every sink (rerun waits at most 5 s for a viewer that went away), name the .rrd, stop our servers."""
    try:
        _disconnect_bounded(rec)
    finally:
        if outlets.rrd is not None:
            if keep_rrd:
                outlets.rrd.commit()
            else:
                outlets.rrd.abort()
        stop_children([p for p in outlets.children if "--serve-web" in p.args])


def _disconnect_bounded(rec: Any, seconds: float = 5.5) -> None:
    """rerun's disconnect waits up to 5 s for a viewer that went away, and for ever on a peer that stopped
    answering mid-stream; past ``seconds`` we leave it (and rerun's own exit hook, which would wait too)."""
    import rerun

    closing = threading.Thread(target=rec.disconnect, name="rerun-disconnect", daemon=True)
    closing.start()
    try:
        closing.join(seconds)
    except KeyboardInterrupt:  # Ctrl-C while closing: leave now, and let no exit hook wait either
        rerun.unregister_shutdown()
        raise
    rerun.unregister_shutdown()  # we closed it ourselves, in bounded time; rerun's exit hook would flush without a limit
    if closing.is_alive():
        from ...console import warn

        warn(f"the viewer connection did not close within {seconds:g} s; left open")


def stop_children(children: list[subprocess.Popen]) -> None:
    for proc in children:
        if proc.poll() is None:
            proc.terminate()
            try:
                proc.wait(5)
            except subprocess.TimeoutExpired:
                proc.kill()
                proc.wait()
