"""The rules of the ``smeha`` command line: its parser and one type per kind of argument.

Every command of :mod:`smeha.cli` builds its options from these, so a rule holds
for every option of its kind and a new command gets the same checks:

* :class:`Parser` reports a bad command line on one line, naming the argument,
  with exit status 2 and no traceback (argparse prints the whole usage first).
* Input files (:func:`input_file`): a missing path or a directory is refused
  while the command line is parsed, before any work starts.
* Output files and folders (:func:`output_file`, :func:`plot_file`, :func:`output_dir`):
  the folder they go into must exist and take a file, checked while parsing, so a path
  that cannot be written fails at once instead of after a long run; nothing is created
  outside the path named (an output under a missing folder is refused, as ``cp`` does).
* Numbers (:func:`setting_type`, :func:`number`, :func:`count`): a range per option, read
  from its declaration (:class:`smeha.settings.Setting`) where the study has one, and the
  message repeats the option, the value typed and the allowed range with its unit.
* Negative numbers (:func:`join_negative_values`): ``--load -100`` works as
  ``--load=-100`` does. Python 3.11's argparse takes ``-100`` for a value but
  ``-1e2`` or ``-100,0`` for an unknown option; Python 3.14 widened the same
  rule (CPython issue gh-105712).

Errors found after parsing that still come before the work (two options that
contradict each other, a file whose content is wrong) raise :class:`UsageError`;
:func:`smeha.cli.main` prints them on one line with exit status 2.
"""
from __future__ import annotations

import argparse
import os
import re
import sys
import tempfile
from pathlib import Path

from gmt.errors import InputError  # cheap: the standard library only

from .settings import Setting

__all__ = ["UsageError", "Parser", "join_negative_values", "input_file", "fmu_file", "output_file",
           "plot_file", "output_dir", "setting_type", "setting_list", "number", "number_list",
           "count", "scheduler_address", "add_branch_rule", "say", "warn"]


class UsageError(InputError):
    """Bad input to a command that argparse cannot check (exit status 2)."""


class Parser(argparse.ArgumentParser):
    """argparse with a one-line error: ``smeha flow: error: argument --step: ...``.

    Options are not abbreviated: ``--frequency`` is not taken for ``--frequencies``.
    """

    def __init__(self, *args, **kwargs):
        kwargs.setdefault("allow_abbrev", False)
        super().__init__(*args, **kwargs)

    def error(self, message):
        self.exit(2, f"{self.prog}: error: {message} (see '{self.prog} --help')\n")


#: A token that starts like a negative number: -100, -1e2, -.5, -100,0 (a list).
_NEGATIVE = re.compile(r"-\.?\d")


def join_negative_values(argv):
    """``--opt -100`` -> ``--opt=-100`` for every long option followed by a negative number.

    No option of ``smeha`` is spelt like a number, so a token such as ``-1e2``
    after a long option can only be that option's value (see the module
    docstring). An option that takes no value still refuses it (exit 2).
    """
    out = []
    for token in argv:
        previous = out[-1] if out else ""
        if (_NEGATIVE.match(token) and previous.startswith("--") and previous != "--"
                and "=" not in previous):
            out[-1] = f"{previous}={token}"
        else:
            out.append(token)
    return out


# -- files --------------------------------------------------------------------------------
def _path(text: str) -> Path:
    if not text.strip():
        raise argparse.ArgumentTypeError("an empty path")
    return Path(text)


def input_file(text: str) -> Path:
    """An existing, readable file (argparse type)."""
    path = _path(text)
    if path.is_dir():
        raise argparse.ArgumentTypeError(f"{text} is a directory, not a file")
    if not path.exists():
        raise argparse.ArgumentTypeError(f"{text}: no such file")
    if not os.access(path, os.R_OK):
        raise argparse.ArgumentTypeError(f"{text}: cannot read it (permission denied)")
    return path


def fmu_file(text: str) -> Path:
    """An existing FMU (argparse type): a zip archive holding ``modelDescription.xml`` (FMI
    2.0 and 3.0 alike); a file of another kind is refused while parsing."""
    import zipfile

    path = input_file(text)
    try:
        with zipfile.ZipFile(path) as archive:
            names = set(archive.namelist())
    except (zipfile.BadZipFile, OSError):
        raise argparse.ArgumentTypeError(f"{text} is not an FMU (not a zip archive)") from None
    if "modelDescription.xml" not in names:
        raise argparse.ArgumentTypeError(f"{text} is not an FMU (a zip archive without "
                                         "modelDescription.xml)")
    return path


def _writable_folder(folder: Path, text: str) -> None:
    """Refuse unless ``folder`` exists and takes a file (a probe, not os.access: permissions
    alone do not tell, e.g. for root or on a read-only mount). Nothing is created: an
    output under a missing folder is refused, as ``cp`` refuses it."""
    folder = folder if str(folder) else Path(".")
    if not folder.exists():
        existing = next((p for p in folder.parents if p.exists()), Path("."))
        if not existing.is_dir():
            raise argparse.ArgumentTypeError(f"{text}: {existing} is a file, not a folder")
        raise argparse.ArgumentTypeError(f"{text}: no such folder {folder} (create it first)")
    if not folder.is_dir():
        raise argparse.ArgumentTypeError(f"{text}: {folder} is a file, not a folder")
    try:
        with tempfile.TemporaryFile(dir=folder):
            pass
    except OSError as exc:
        raise argparse.ArgumentTypeError(
            f"{text}: cannot write into the folder {folder} ({exc.strerror or exc})") from None


def output_file(text: str) -> Path:
    """A file to write, in a folder that exists (argparse type). Nothing is written while
    parsing; the command writes it whole or not at all (:mod:`smeha.outputs`)."""
    path = _path(text)
    if path.is_dir():
        raise argparse.ArgumentTypeError(f"{text} is a directory; give a file name")
    _writable_folder(path.parent, text)
    if path.exists() and not os.access(path, os.W_OK):
        raise argparse.ArgumentTypeError(f"{text}: cannot write it (permission denied)")
    return path


#: The formats a plot is written in, by the file name's suffix (matplotlib's Agg backend).
PLOT_SUFFIXES = (".png", ".pdf", ".svg")


def plot_file(text: str) -> Path:
    """An image to write (argparse type): :func:`output_file` whose suffix names a format of
    :data:`PLOT_SUFFIXES`."""
    path = output_file(text)
    if path.suffix.lower() not in PLOT_SUFFIXES:
        raise argparse.ArgumentTypeError(
            f"{text}: a plot is written as {', '.join(s[1:].upper() for s in PLOT_SUFFIXES)} "
            f"by its name's suffix, and {path.suffix or 'no suffix'!r} is none of them "
            f"(e.g. {path.with_suffix('.png').name})")
    return path


def output_dir(text: str) -> Path:
    """A folder to write files into (argparse type): an existing one, or a new one in a
    folder that exists (the command creates it when it writes; no parents are made)."""
    path = _path(text)
    if path.exists() and not path.is_dir():
        raise argparse.ArgumentTypeError(f"{text} is a file, not a folder")
    _writable_folder(path if path.exists() else path.parent, text)
    return path


# -- numbers ------------------------------------------------------------------------------
def setting_type(setting: Setting):
    """The argparse type of a declared setting (:class:`smeha.settings.Setting`): its range,
    its message, its whole-number rule, read from the one declaration."""
    def convert(text):
        reason = setting.refusal(text)
        if reason is not None:
            raise argparse.ArgumentTypeError(reason)
        value = float(text)
        return int(value) if setting.whole else value

    convert.numeric = True  # tests/test_cli_input.py drives every numeric option
    convert.setting = setting
    return convert


def number(low=None, high=None, *, low_open=True, high_open=False, unit=""):
    """An argparse type: a finite float in the range (``low``, ``high``].

    ``None`` leaves a side unbounded; ``low_open``/``high_open`` exclude the bound.
    """
    return setting_type(Setting("value", unit, low, high, low_open, high_open))


def setting_list(setting: Setting):
    """An argparse type: comma-separated values of ``setting``, each checked as one."""
    one = setting_type(setting)

    def convert(text):
        items = [v.strip() for v in text.split(",")]
        if not any(items):
            raise argparse.ArgumentTypeError(f"{text!r} is not a comma-separated list of "
                                             "numbers")
        if not all(items):  # "50,,100", "50,": a number left out, not a shorter list
            raise argparse.ArgumentTypeError(f"{text!r} has an empty item; give numbers "
                                             "separated by single commas")
        return [one(v) for v in items]

    convert.numeric = True
    convert.setting = setting
    return convert


def number_list(low=None, high=None, *, low_open=True, high_open=False, unit=""):
    """An argparse type: comma-separated numbers, each checked as :func:`number`."""
    return setting_list(Setting("value", unit, low, high, low_open, high_open))


def count(low=1, high=None):
    """An argparse type: a whole number in [``low``, ``high``] (``None``: unbounded)."""
    return setting_type(Setting("count", "", low, high, low_open=False, whole=True))


#: A Dask scheduler address: [protocol://]host:port.
_ADDRESS = re.compile(r"([a-z]+://)?[^\s:/]+:\d+")


def scheduler_address(text: str) -> str:
    """A Dask scheduler address such as tcp://host:8786 (argparse type; not connected here)."""
    if not _ADDRESS.fullmatch(text.strip()):
        raise argparse.ArgumentTypeError(f"{text!r} is not a scheduler address "
                                         "[protocol://]host:port, e.g. tcp://10.0.0.5:8786")
    return text.strip()


def add_branch_rule(parser) -> None:
    """--branch-rule, the compensator's root rule (gmt.parameters.BRANCH_RULES)."""
    import gmt.parameters

    default = gmt.parameters.BRANCH_RULE
    parser.add_argument("--branch-rule", choices=gmt.parameters.BRANCH_RULES, default=default,
                        help="compensator root rule: 'control' (Figure 9's sign of u(n) - "
                             "u(n-1); its result depends on the sample period) or 'demand' "
                             "(the direction of the demanded magnetisation); default "
                             f"{default!r}")


def say(message: str) -> None:
    """A notice on stderr (a long preparation starting), printed at once."""
    print(message, file=sys.stderr, flush=True)


def warn(command: str, message: str) -> None:
    """A warning on stderr, one line, in the form of the errors."""
    print(f"smeha {command}: warning: {message}", file=sys.stderr)
