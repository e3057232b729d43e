"""Progress of a diagnosis: the current step, shown as a bar once the answer takes long.

The library prints nothing by itself; a caller that wants the bar (the CLI) runs the
diagnosis inside :func:`shown`. Each batch of fits (:func:`smeha.diagnose.fit.fit_all`)
then draws a bar on stderr labelled with the current step (:func:`step`: "single causes",
"second cause beside magnetization_saturation", ...), from the first batch that starts
once the diagnosis has run :data:`SHOW_AFTER` seconds: a quick answer stays quiet.
"""
from __future__ import annotations

import contextlib
import contextvars
import time

__all__ = ["SHOW_AFTER", "shown", "step", "bar_settings"]

#: Seconds of a diagnosis after which its batches of fits show a progress bar.
SHOW_AFTER = 5.0

_STARTED = contextvars.ContextVar("diagnosis_started", default=None)
_STEP = contextvars.ContextVar("diagnosis_step", default="fits")


@contextlib.contextmanager
def shown():
    """Within it, batches of fits that start :data:`SHOW_AFTER` s after its start show a
    bar on stderr with the current step."""
    token = _STARTED.set(time.perf_counter())
    try:
        yield
    finally:
        _STARTED.reset(token)


def step(label: str) -> None:
    """Name the step the next batches of fits belong to."""
    _STEP.set(label)


def bar_settings() -> tuple:
    """(desc, quiet) for the next batch's bar (:func:`smeha.pool.run_jobs`)."""
    started = _STARTED.get()
    quiet = started is None or time.perf_counter() - started < SHOW_AFTER
    return _STEP.get(), quiet
