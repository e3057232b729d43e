"""Ctrl-C while an FMU is stepping: the interrupt waits until the FMU call returns.

A Python FMU (pythonfmu) runs its slave's Python code inside the host's interpreter,
called from the FMU's C library. Python raises ``KeyboardInterrupt`` in whichever Python
frame runs when SIGINT arrives; when that frame is the slave's (its ``do_step``, or the
physics it calls), the exception crosses the FMU's C boundary, where pythonfmu turns it
into ``fmi2Fatal``: the host sees ``fmi2DoStep failed with status 4 (fatal)`` instead
of an interrupt, and the FMU instance is lost. The FMI standard gives a host no way to
cancel a running step (FMI 2.0's ``fmi2CancelStep`` applies to a step that returned
``fmi2Pending`` only). The FMU also calls back into the host's Python through ctypes
(fmpy's logger); an exception raised there is printed and dropped by ctypes ("Exception
ignored on calling ctypes callback function"), so a Ctrl-C landing there would be lost
and the run would go on. In both places the interrupt is held until the call returns:

:func:`fmu_safe_interrupts` installs a SIGINT handler that raises ``KeyboardInterrupt``
at once, as Python's own does, unless a frame of such code is on the stack; then it
delivers SIGINT again :data:`REDELIVER_AFTER` later, until the stack holds none. A step
takes tens of microseconds, so the command stops within a few hundredths of a second.
"""
from __future__ import annotations

import contextlib
import functools
import os
import signal
import threading
from pathlib import Path

__all__ = ["REDELIVER_AFTER", "fmu_safe_interrupts", "in_fmu"]

#: Delay before a held SIGINT is delivered again, [s].
REDELIVER_AFTER = 0.02


@functools.lru_cache(maxsize=1024)
def _fmu_code(filename: str) -> bool:
    """Whether ``filename`` is code an FMU runs or calls back: a file under an extracted
    FMU's ``resources`` folder (beside its ``modelDescription.xml``), pythonfmu's slave
    classes, which its C library calls, or fmpy, whose callbacks the FMU calls."""
    path = Path(filename)
    if {"pythonfmu", "pythonfmu3", "fmpy"} & set(path.parts):
        return True
    for folder in list(path.parents)[:4]:
        if folder.name == "resources" and (folder.parent / "modelDescription.xml").is_file():
            return True
    return False


def in_fmu(frame) -> bool:
    """Whether ``frame`` or any frame that called it runs an FMU's code."""
    while frame is not None:
        if _fmu_code(frame.f_code.co_filename):
            return True
        frame = frame.f_back
    return False


def _redeliver() -> None:
    timer = threading.Timer(REDELIVER_AFTER, os.kill, (os.getpid(), signal.SIGINT))
    timer.daemon = True
    timer.start()


def _handler(signum, frame):
    if in_fmu(frame):
        _redeliver()
        return
    raise KeyboardInterrupt


@contextlib.contextmanager
def fmu_safe_interrupts():
    """A context in which SIGINT raises ``KeyboardInterrupt`` outside FMU code only (module
    docstring); the previous handler is restored at its end. Outside the main thread (where
    Python handles no signals) it does nothing."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    previous = signal.signal(signal.SIGINT, _handler)
    try:
        yield
    finally:
        signal.signal(signal.SIGINT, previous)
