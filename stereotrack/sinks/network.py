"""Live tracks for other programs: each frame as a UDP datagram (JSON, or an OSC bundle) to the addresses given.

Sending never holds the tracker back: each frame is encoded (JSON: about
0.1 ms for four balls on the loaded 2-core machine) and handed to
non-blocking sockets right after the tracker step, so it leaves at once; a datagram the kernel cannot take is dropped and
counted, never waited for. (A sender thread would add latency, not save
time: encoding holds the GIL wherever it runs; measured in BENCHMARKS.md.)
UDP needs no receiver: an absent, slow or vanished receiver costs the
tracker nothing. Nothing listens; datagrams go only to the addresses the
user gave.
"""

from __future__ import annotations

import argparse
import math
import socket
import threading
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass

from ..config import Config
from ..console import info, warn
from ..errors import StereotrackError
from ..results import FrameResult
from .datagram import FrameTracks, encode_json, message, osc_encoder

RESOLVE_SECONDS = 5.0  # a host name that takes longer to resolve is an error, not a hang
ADDRESS_HELP = "expected HOST:PORT, e.g. 127.0.0.1:9870 or robot.local:9870 ([::1]:9870 for an IPv6 address)"


@dataclass(frozen=True)
class Destination:
    protocol: str  # "udp" (JSON datagrams) or "osc" (OSC bundles)
    text: str  # as the user wrote it
    family: int  # socket.AF_INET or AF_INET6
    address: tuple  # the resolved socket address

    def __str__(self) -> str:
        return f"{self.text} ({self.protocol})"


def _resolve(host: str, port: int, seconds: float) -> list | None:
    """getaddrinfo with a time limit (it has none of its own): the results, or None on timeout; socket.gaierror passes."""
    out: dict = {}

    def work():
        try:
            out["infos"] = socket.getaddrinfo(host, port, type=socket.SOCK_DGRAM)
        except OSError as exc:
            out["error"] = exc

    thread = threading.Thread(target=work, name="resolve", daemon=True)
    thread.start()
    thread.join(seconds)
    if "error" in out:
        raise out["error"]
    return out.get("infos")


def parse_destination(text: str, protocol: str = "udp", resolve_seconds: float = RESOLVE_SECONDS) -> Destination:
    """``HOST:PORT`` (``[IPv6]:PORT``) -> a resolved Destination; anything wrong is one StereotrackError line."""
    where = f"--{protocol} {text!r}"
    s = text.strip()
    if s.startswith("["):
        host, close, rest = s[1:].partition("]")
        port_text = rest[1:] if close and rest.startswith(":") else None
    else:
        host, sep, port_text = s.rpartition(":")
        port_text = port_text if sep and ":" not in host else None
    if not host or not port_text:
        raise StereotrackError(f"{where}: {ADDRESS_HELP}")
    try:
        port = int(port_text)
    except ValueError:
        raise StereotrackError(f"{where}: the port must be a whole number 1..65535, got {port_text!r}") from None
    if not 1 <= port <= 65535:
        raise StereotrackError(f"{where}: port {port} is out of range 1..65535")
    try:
        infos = _resolve(host, port, resolve_seconds)
    except (OSError, UnicodeError) as exc:
        reason = exc.strerror if isinstance(exc, OSError) and exc.strerror else str(exc)
        raise StereotrackError(f"{where}: cannot resolve host {host!r} ({reason}); check the name, or give an IP address") from None
    if infos is None:
        raise StereotrackError(f"{where}: resolving host {host!r} took over {resolve_seconds:g} s; give an IP address instead")
    family, _, _, _, address = next((i for i in infos if i[0] == socket.AF_INET), infos[0])
    return Destination(protocol, text, family, address)


class NetworkSink:
    """Sends every frame's reported tracks to each destination as it is written; ``write`` never waits.

    The sockets are non-blocking: a datagram the kernel cannot take at once
    (send buffer full) is dropped and counted, never waited for. UDP needs no
    receiver, so an absent, slow or vanished one costs nothing. ``clock`` must
    be the capture clock (live cameras: time.monotonic) so that ``sent - time``
    is the latency.
    """

    def __init__(
        self,
        destinations: Sequence[Destination],
        landing_height: float | None = None,
        clock: Callable[[], float] = time.monotonic,
        quiet: bool = False,
    ):
        if not destinations:
            raise ValueError("NetworkSink needs at least one destination")
        self.destinations = tuple(destinations)
        self.landing_height = landing_height
        self.clock = clock
        self.quiet = quiet
        self._encoders = {"udp": encode_json}
        if any(d.protocol == "osc" for d in self.destinations):
            self._encoders["osc"] = osc_encoder()
        self._sockets: dict[int, socket.socket] = {}
        for family in {d.family for d in self.destinations}:
            sock = socket.socket(family, socket.SOCK_DGRAM)
            sock.setblocking(False)  # a full send buffer drops a datagram instead of stalling the tracker
            if family == socket.AF_INET:
                sock.setsockopt(socket.SOL_SOCKET, socket.SO_BROADCAST, 1)  # so a broadcast address the user gave works
            self._sockets[family] = sock
        self.frames = 0  # frames written
        self.sent = 0  # datagrams sent, over all destinations
        self.dropped = 0  # datagrams dropped because the send buffer was full
        self.failed = 0  # datagrams that could not be sent (no route, too large, ...) or frames that could not be encoded
        self.first_error: str | None = None

    def write(self, result: FrameResult) -> None:
        self.frames += 1
        item = FrameTracks(result.frame.index, result.frame.timestamps, result.confirmed)
        try:
            msg = message(item, self.clock(), self.landing_height)
            payloads = {protocol: encode(msg) for protocol, encode in self._encoders.items()}
        except Exception as exc:  # a frame that cannot be encoded must not end the run
            self._failure(f"encoding frame {item.frame}: {type(exc).__name__}: {exc}")
            return
        for d in self.destinations:
            try:
                self._sockets[d.family].sendto(payloads[d.protocol], d.address)
                self.sent += 1
            except BlockingIOError:
                self.dropped += 1
            except OSError as exc:  # no route, message too long, ...
                self._failure(f"sending to {d}: {exc}")

    def close(self) -> None:
        if not self._sockets:
            return
        for sock in self._sockets.values():
            sock.close()
        self._sockets = {}
        if not self.quiet:
            where = ", ".join(str(d) for d in self.destinations)
            info(
                f"network: {self.frames} frames to {where}: {self.sent} datagrams sent, "
                f"{self.dropped} dropped (send buffer full), {self.failed} failed"
            )

    def _failure(self, what: str) -> None:
        self.failed += 1
        if self.first_error is None:
            self.first_error = what
            warn(f"network: {what} (the run goes on; later failures are only counted)")


# ---------------------------------------------------------------------- command-line flags


def _height(text: str) -> float:
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a height in metres, got {text!r}") from None
    if not math.isfinite(value) or abs(value) > 1000:
        raise argparse.ArgumentTypeError(f"expected a height between -1000 and 1000 metres, got {text!r}")
    return value


def add_network_arguments(parser: argparse.ArgumentParser) -> None:
    """The network flags shared by `track`, `live` and `demo`."""
    g = parser.add_argument_group("network output (each frame's tracks to other programs; UDP is unauthenticated: a local network only)")
    g.add_argument(
        "--udp",
        metavar="HOST:PORT",
        action="append",
        default=[],
        help="send each frame's tracks as a JSON datagram to HOST:PORT (repeatable; schema in docs/formats.md section 5)",
    )
    g.add_argument(
        "--osc",
        metavar="HOST:PORT",
        action="append",
        default=[],
        help="send each frame's tracks as an OSC bundle to HOST:PORT (repeatable; needs python-osc: pip install 'stereotrack[osc]')",
    )
    g.add_argument(
        "--landing-height",
        metavar="METRES",
        type=_height,
        default=None,
        help="for a ball in free flight, send where it will come down through this height along the world's up axis "
        "(needs tracks.up; default 0)",
    )


def check_network_flags(args: argparse.Namespace) -> list[Destination]:
    """Parse and resolve every --udp/--osc address once, up front (a bad one is one line, exit 2, before any
    work or output starts); the parsed destinations replace the texts in ``args``, so a second call is free."""
    out = []
    for protocol in ("udp", "osc"):
        given = getattr(args, protocol, None) or []
        parsed = [d if isinstance(d, Destination) else parse_destination(d, protocol) for d in given]
        if given:
            setattr(args, protocol, parsed)
        out += parsed
    if any(d.protocol == "osc" for d in out):
        osc_encoder()  # python-osc missing: say so now
    return out


def make_network_sink(args: argparse.Namespace, config: Config, quiet: bool = False) -> NetworkSink | None:
    """The NetworkSink the flags ask for, or None without --udp/--osc."""
    destinations = check_network_flags(args)
    if not destinations:
        return None
    height = getattr(args, "landing_height", None)
    if config.tracks.up is None:
        if height is not None:
            warn("--landing-height needs the world's up axis (tracks.up in the config, or 'up' in the recording): no landing points sent")
        height = None
    elif height is None:
        height = 0.0
    return NetworkSink(destinations, landing_height=height, quiet=quiet)
