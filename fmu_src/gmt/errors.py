"""Exceptions raised by the transducer physics."""


class GmtError(Exception):
    """Base class of every error raised by :mod:`gmt`."""


class InputError(ValueError):
    """Bad input: a usage, data or parameter error the user can mend (the package's
    family, :mod:`smeha.errors`; the command line answers it with exit status 2)."""


class RunError(RuntimeError):
    """A run that stopped: an integration, a coupling, a sweep or a build that failed on
    good input (the package's family, :mod:`smeha.errors`; exit status 1)."""


class ParameterError(GmtError, InputError):
    """A parameter or input is outside the range the model is defined for.

    The message names the parameter, the value received and the allowed range,
    e.g. ``rod_length = -0.08 m is outside the allowed range (0, inf) m``.
    """


class ConvergenceError(GmtError, RunError):
    """An iterative solver of the physics stopped without meeting its tolerance.

    The message names the quantity solved for, the target and the bracket left.
    """


def check_range(name, value, low=None, high=None, *, unit="", low_open=True,
                high_open=True):
    """Raise :class:`ParameterError` unless ``low < value < high``.

    Parameters
    ----------
    name : str
        Parameter name used in the message.
    value : float
        Value to check; NaN always fails.
    low, high : float or None
        Bounds; ``None`` means unbounded on that side.
    unit : str
        Unit shown in the message.
    low_open, high_open : bool
        Whether the bound itself is excluded (default) or allowed.

    Returns
    -------
    float
        ``value`` as a float, so the call can be used inline.
    """
    try:
        v = float(value)
    except (TypeError, ValueError):
        raise ParameterError(f"{name} = {value!r} is not a number") from None
    ok = v == v  # NaN check
    if ok and low is not None:
        ok = v > low if low_open else v >= low
    if ok and high is not None:
        ok = v < high if high_open else v <= high
    if not ok:
        lo = "-inf" if low is None else f"{low:g}"
        hi = "inf" if high is None else f"{high:g}"
        lb = "(" if (low_open or low is None) else "["
        hb = ")" if (high_open or high is None) else "]"
        u = f" {unit}" if unit else ""
        raise ParameterError(
            f"{name} = {v:g}{u} is outside the allowed range {lb}{lo}, {hi}{hb}{u}")
    return v
