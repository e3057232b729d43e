"""Ctrl-C: exit status 130 and one line, never an FMU's fatal error, never a half-written file.

A Python FMU runs its slave's code in the host's interpreter; a KeyboardInterrupt raised
there crosses the FMU's C boundary, which pythonfmu turns into fmi2Fatal
(``fmi2DoStep failed with status 4``, 1 of 6 Ctrl-C tries of ``smeha simulate``). The
fake FMU below stands in for it: a module under an extracted FMU's ``resources`` folder
that, as pythonfmu's C wrapper does, turns any exception into a fatal status.
"""
from __future__ import annotations

import os
import signal
import sys
import threading
import time

import pytest

from smeha import cli, interrupt, outputs

SLAVE = '''
import os
import signal
import time

def do_step(seconds):
    """Step for ``seconds`` of busy work, a Ctrl-C arriving at its start; any exception is
    a fatal status (pythonfmu)."""
    try:
        os.kill(os.getpid(), signal.SIGINT)
        end = time.perf_counter() + seconds
        while time.perf_counter() < end:
            pass
        return "ok"
    except BaseException:
        return "fatal"
'''


#: The tests that send SIGINT into the test process itself. Open problem: under Python 3.13
#: such a SIGINT is raised past the handler's context (it ends the test runner's worker)
#: instead of waiting for the step; they run on 3.11 and 3.12 (CHANGELOG, known problems).
SELF_SIGNAL = pytest.mark.skipif(sys.version_info >= (3, 13), reason=(
    "open: under Python 3.13 a SIGINT sent to the test process escapes the handler's context"))


def _module(path, source):
    """``source`` written to ``path`` (its folder made) and imported from there."""
    import importlib.util
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(source)
    spec = importlib.util.spec_from_file_location(path.stem, path)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


@pytest.fixture
def fake_fmu(tmp_path):
    """The ``do_step`` of a slave module loaded from an extracted FMU's resources folder."""
    (tmp_path / "modelDescription.xml").write_text("<fmiModelDescription/>")
    return _module(tmp_path / "resources" / "fake_slave.py", SLAVE).do_step


def _sigint_after(seconds):
    timer = threading.Timer(seconds, os.kill, (os.getpid(), signal.SIGINT))
    timer.start()
    return timer


@SELF_SIGNAL
def test_sigint_inside_the_fmu_waits_for_the_step(fake_fmu):
    statuses = []
    with interrupt.fmu_safe_interrupts(), pytest.raises(KeyboardInterrupt):
        statuses.append(fake_fmu(0.3))  # the signal lands inside the step
        start = time.perf_counter()
        while time.perf_counter() - start < 10.0:  # the host's loop, between steps
            pass
    assert statuses == ["ok"]  # the step finished: no fatal status
    assert time.perf_counter() - start < 5.0  # and the interrupt came after it, not never


@SELF_SIGNAL
def test_without_the_handler_the_step_turns_fatal(fake_fmu):
    # the failure the handler prevents, shown with Python's own handler
    previous = signal.signal(signal.SIGINT, signal.default_int_handler)
    try:
        assert fake_fmu(0.3) == "fatal"
    finally:
        signal.signal(signal.SIGINT, previous)


LOGGER = '''
import os
import signal
import time

def log(message):
    """The host's logger, called back by an FMU through ctypes; a Ctrl-C arrives in it."""
    os.kill(os.getpid(), signal.SIGINT)
    end = time.perf_counter() + 0.2
    while time.perf_counter() < end:
        pass
'''


@pytest.fixture
def fmu_callback(tmp_path):
    """fmpy's logger as an FMU calls it: a Python function of the fmpy package entered from
    C through a ctypes callback (an exception there is printed and dropped by ctypes)."""
    import ctypes
    module = _module(tmp_path / "fmpy" / "fake_logger.py", LOGGER)
    kind = ctypes.CFUNCTYPE(None, ctypes.c_char_p)
    callback = kind(module.log)
    through_c = kind(ctypes.cast(callback, ctypes.c_void_p).value)  # called from C
    return lambda: through_c(b"message"), callback


@SELF_SIGNAL
def test_sigint_in_a_callback_from_the_fmu_is_not_lost(fmu_callback, monkeypatch):
    import sys
    call, _keep = fmu_callback
    dropped = []
    monkeypatch.setattr(sys, "unraisablehook", lambda u: dropped.append(u.exc_type))
    with interrupt.fmu_safe_interrupts(), pytest.raises(KeyboardInterrupt):
        call()
        start = time.perf_counter()
        while time.perf_counter() - start < 10.0:
            pass
    assert dropped == []
    # with Python's own handler the interrupt is dropped by ctypes, and the host goes on
    previous = signal.signal(signal.SIGINT, signal.default_int_handler)
    try:
        call()
    finally:
        signal.signal(signal.SIGINT, previous)
    assert dropped == [KeyboardInterrupt]


@SELF_SIGNAL
def test_sigint_outside_an_fmu_interrupts_at_once():
    with interrupt.fmu_safe_interrupts(), pytest.raises(KeyboardInterrupt):
        _sigint_after(0.02)
        time.sleep(1.0)


def test_main_reports_an_interrupt_on_one_line(monkeypatch, capsys):
    from smeha.studies import flow

    def interrupted(*args, **kwargs):
        raise KeyboardInterrupt
    monkeypatch.setattr(flow, "ensure_fmu", interrupted)
    assert cli.main(["flow", "--frequencies", "100"]) == 130
    err = capsys.readouterr().err
    assert err.strip() == "smeha flow: interrupted" and "Traceback" not in err


def test_an_interrupted_write_leaves_no_file(tmp_path):
    target = tmp_path / "table.csv"
    target.write_text("old\n")
    with pytest.raises(KeyboardInterrupt), outputs.replacing(target) as tmp:
        tmp.write_text("half of the new")
        raise KeyboardInterrupt
    assert target.read_text() == "old\n"  # the previous file, whole
    assert sorted(p.name for p in tmp_path.iterdir()) == ["table.csv"]  # no temporary left
    with outputs.replacing(target) as tmp:
        tmp.write_text("new\n")
    assert target.read_text() == "new\n"
    assert oct(target.stat().st_mode & 0o777) == oct(0o666 & ~_umask())


def _umask():
    mask = os.umask(0o022)
    os.umask(mask)
    return mask


@pytest.mark.integration  # a real command, interrupted (~6 s)
def test_ctrl_c_stops_flow_and_its_workers(tmp_path):
    # a terminal's Ctrl-C reaches every process of the command: the workers leave it to
    # the parent, which stops them and exits 130 with one line; no output is left half-done
    import subprocess
    import sys
    proc = subprocess.Popen(
        [sys.executable, "-c", "import sys; from smeha.cli import main; sys.exit(main())",
         "flow", "--backend", "direct", "--workers", "2", "--cycles", "400",
         "--plot", str(tmp_path / "flow.png")],
        stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, start_new_session=True)
    time.sleep(6.0)
    children = _children(proc.pid)
    os.killpg(proc.pid, signal.SIGINT)
    out, err = proc.communicate(timeout=60)
    lines = [ln for ln in err.replace("\r", "\n").splitlines() if ln.strip() and "|" not in ln]
    assert proc.returncode == 130, err
    assert lines[-1] == "smeha flow: interrupted" and "Traceback" not in err
    assert list(tmp_path.iterdir()) == []
    time.sleep(0.5)
    assert not [c for c in children if _alive(c)]  # the workers were stopped


def _children(pid):
    try:
        with open(f"/proc/{pid}/task/{pid}/children") as fh:
            return [int(c) for c in fh.read().split()]
    except OSError:
        return []


def _alive(pid):
    try:
        with open(f"/proc/{pid}/stat") as fh:
            return fh.read().split()[2] != "Z"
    except OSError:
        return False
