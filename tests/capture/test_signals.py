"""Stop signals never break an import, and every thread a stop leaves behind is waited for in bounded time.

The whole-command versions (hundreds of signals in the first second of live,
record and track) are in benchmarks/early_signals.py.
"""

from __future__ import annotations

import subprocess
import sys
import textwrap
import threading
import time
from pathlib import Path

import numpy as np

from stereotrack.capture.cameras import CameraPairSource, CapturedPair
from stereotrack.sinks.recorder import RecordingSink

ROOT = Path(__file__).resolve().parents[2]

# A module whose import is interrupted by a stop signal half-way through (the signal comes from inside it,
# so the moment is exact), then does more work: the last line shows whether the import completed.
SLOW_MODULE = """
import os, signal, time
if "SIGNALLED" not in os.environ:  # once: a second import (after a broken first one) is not signalled
    os.environ["SIGNALLED"] = "1"
    os.kill(os.getpid(), signal.{sig})
    time.sleep(0.05)  # the handler runs here
for _ in range(1000):
    pass
COMPLETE = True
"""

SCRIPT = """
import sys, threading, time
from stereotrack.capture.signals import Interrupted, install, {scope}
install()
stopped = "no stop"
try:
    {enter}
        import slow_module
        stopped = "lost"  # a deferred stop must still come, at the next safe point
        for _ in range(200):
            time.sleep(0.01)
            if {requested}:
                stopped = "requested"
                break
except Interrupted as exc:
    stopped = "interrupted " + exc.signal_name
print(stopped)
print("complete", getattr(sys.modules.get("slow_module"), "COMPLETE", False))
other = threading.Thread(target=lambda: __import__("slow_module"), daemon=True)  # no import lock left held
other.start()
other.join(5)
print("other thread imported", not other.is_alive())
"""


def run_script(tmp_path: Path, sig: str, in_scope: bool) -> list[str]:
    (tmp_path / "slow_module.py").write_text(SLOW_MODULE.format(sig=sig))
    script = SCRIPT.format(
        scope="StopOnSignals" if in_scope else "stop_requested",
        enter="with StopOnSignals() as stopper:" if in_scope else "if True:",
        requested="stopper.requested" if in_scope else "False",
    )
    res = subprocess.run(
        [sys.executable, "-c", textwrap.dedent(script)],
        cwd=tmp_path,
        env={"PYTHONPATH": f"{tmp_path}:{ROOT}", "PATH": "/usr/bin:/bin"},
        capture_output=True,
        text=True,
        timeout=60,
    )
    assert res.returncode == 0 and "Traceback" not in res.stderr, res.stderr
    return res.stdout.split("\n")[:3]


def test_a_stop_signal_inside_an_import_is_raised_after_it_not_in_it(tmp_path):
    for sig in ("SIGTERM", "SIGINT"):
        stopped, complete, other = run_script(tmp_path, sig, in_scope=False)
        assert stopped == f"interrupted {sig}"  # not lost: raised as soon as the import was done
        assert complete == "complete True"  # the module was not left half-imported
        assert other == "other thread imported True"


def test_a_stop_signal_inside_an_import_in_a_stoppable_block_asks_the_loop_to_stop(tmp_path):
    assert run_script(tmp_path, "SIGTERM", in_scope=True) == ["requested", "complete True", "other thread imported True"]


class StuckDevice:
    """A device whose grab blocks in its 'driver' and ignores interrupt(), like a webcam that never returns."""

    finite = False

    def __init__(self):
        self.release_driver = threading.Event()

    def isOpened(self):
        return True

    def get(self, prop):
        return 0.0

    def set(self, prop, value):
        return False

    def grab(self):
        self.release_driver.wait(30)
        return False

    def retrieve(self):
        return False, None

    def release(self):
        pass


def test_closing_a_source_whose_camera_never_returns_takes_bounded_time_and_says_so(capsys):
    stuck = [StuckDevice(), StuckDevice()]
    src = CameraPairSource(stuck)
    start = time.monotonic()
    src.close(timeout=0.3)
    assert time.monotonic() - start < 3.0
    err = capsys.readouterr().err
    assert err.count("did not stop within 0.3 s") == 2, err
    for d in stuck:
        d.release_driver.set()


def test_closing_a_recorder_whose_disk_stopped_answering_takes_bounded_time_and_says_so(tmp_path, capsys):
    sink = RecordingSink(tmp_path / "rec", ["cam0", "cam1"], 30.0)
    disk = threading.Event()
    sink._write = lambda pair: disk.wait(30)  # the writer thread blocks in its first write
    img = np.zeros((8, 8, 3), np.uint8)
    for k in range(3):
        assert sink.offer(CapturedPair(k, (k / 30, k / 30), (img, img), (None, None)))
    start = time.monotonic()
    sink.close(stall_seconds=0.5)
    assert time.monotonic() - start < 3.0
    err = capsys.readouterr().err
    assert "the writer wrote nothing for 0.5 s" in err and "2 pairs unwritten" in err, err
    disk.set()


def _stop_inside_a_kernel(stop: BaseException) -> None:
    """Call a compiled kernel with ``stop`` raised where a signal lands inside one: in numba's call back into Python that
    loads a kernel's constants (``_numba_unpickle``, thousands of times a second while tracking)."""
    sys.path.insert(0, str(ROOT / "tests"))
    from scene_helpers import default_rig

    camera, point = default_rig().cameras[0], np.array([[0.0, 1.5, 0.0]])
    camera.view(point)  # compiled and loaded

    def tracer(frame, event, arg):
        if event == "call" and frame.f_code.co_name == "_numba_unpickle":
            sys.settrace(None)
            raise stop

    sys.settrace(tracer)
    try:
        camera.view(point)
    finally:
        sys.settrace(None)


def test_a_stop_inside_a_compiled_kernel_is_still_a_stop_not_an_internal_error(monkeypatch, capsys):
    """numba hands a stop raised inside its call back on as a SystemError caused by it (test_viewer's Ctrl-C test saw
    one). It is the user's stop all the same: ``interrupt_in`` finds it, and the command line says "interrupted" with
    the signal's exit status, not "internal error" (exit 3)."""
    from stereotrack import cli
    from stereotrack.capture.signals import Interrupted, interrupt_in
    from stereotrack.commands import bench

    stop = Interrupted("SIGTERM")
    try:
        _stop_inside_a_kernel(stop)
    except BaseException as exc:  # noqa: BLE001 (what numba makes of it is the point)
        raised = exc
    assert isinstance(raised, SystemError) and interrupt_in(raised) is stop
    assert interrupt_in(SystemError("a bug")) is None and interrupt_in(None) is None
    try:  # an error raised while a stop was handled, not by it, is that error
        try:
            raise Interrupted("SIGINT")
        except KeyboardInterrupt:
            raise OSError("the disk failed as the file was closed")  # noqa: B904 (what is tested)
    except OSError as exc:
        assert interrupt_in(exc) is None
    monkeypatch.setattr(bench, "run", lambda args: _stop_inside_a_kernel(Interrupted("SIGTERM")))
    assert cli.main(["bench", "--quick"]) == 128 + 15
    err = capsys.readouterr().err
    assert err.strip() == "interrupted by SIGTERM", err
