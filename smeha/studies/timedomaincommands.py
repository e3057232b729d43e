"""``smeha timedomain``: the time-domain magnetics' studies.

Registered by :mod:`smeha.cli`; the studies are :mod:`smeha.studies.timedomain`.
Nothing heavy is imported before the command runs.
"""
from __future__ import annotations

import json

from ..cliargs import count, plot_file, setting_list
from .flowsettings import FREQUENCY

__all__ = ["STUDIES", "DEFAULT_FREQUENCIES", "add_timedomain"]

STUDIES = ("compare", "waveforms", "gains")
#: Frequencies of each study by default, [Hz].
DEFAULT_FREQUENCIES = {"waveforms": [50.0, 100.0, 150.0, 200.0],
                       "gains": [50.0, 70.0, 80.0, 100.0]}


def add_timedomain(subparsers):
    p = subparsers.add_parser(
        "timedomain", help="the time-domain magnetics against the paper's: side by side, "
                           "drive waveforms, compensation gains",
        description="Studies of the time-domain magnetics (docs/TIMEDOMAIN.md). compare: both "
                    "models under a sinusoidal current at Table 1's points (B_m, mu', mu'', "
                    "lag, loss per cycle, stroke) beside Table 1's measured B_m; waveforms: "
                    "which drive waveform pumps the most flow at equal peak and equal RMS "
                    "coil current, with and without the inverse (realistic circuit); gains: "
                    "the compensation gain of the paper's model, of the time-domain model "
                    "behind the paper's inverse and behind its own, against the paper's "
                    "measured 1.14-1.32. The co-simulations run gmt in-process (the FMU "
                    "gives the same numbers: tests/test_fmu.py).")
    p.add_argument("--study", choices=STUDIES, default="compare",
                   help="which study (default compare)")
    p.add_argument("--frequencies", type=setting_list(FREQUENCY),
                   metavar="HZ,HZ,...",
                   help=f"pumping frequencies, each {FREQUENCY.interval()}, of waveforms "
                        "(default 50,100,150,200) and gains (default 50,70,80,100)")
    p.add_argument("--workers", type=count(1), metavar="N",
                   help="local worker processes for the co-simulations (default 2)")
    p.add_argument("--json", action="store_true", help="print only a JSON object {rows: [...]}")
    p.add_argument("--plot", metavar="FILE", type=plot_file,
                   help="waveforms: write flow against frequency per waveform (PNG)")
    p.set_defaults(run=_run_timedomain)


def _run_timedomain(args) -> int:
    from ..cliargs import UsageError
    from . import timedomain

    if args.plot and args.study != "waveforms":
        raise UsageError(f"--plot draws the waveforms study; --study {args.study} has no plot")
    if args.frequencies and args.study == "compare":
        raise UsageError("--frequencies has no use with --study compare (Table 1's points)")
    workers = args.workers or 2
    freqs = args.frequencies or DEFAULT_FREQUENCIES.get(args.study)
    if args.study == "compare":
        rows, text = timedomain.compare_rows(), timedomain.format_compare
    elif args.study == "waveforms":
        rows = timedomain.waveform_rows(tuple(freqs), workers=workers, quiet=args.json)
        text = timedomain.format_waveforms
    else:
        rows = timedomain.gain_rows(tuple(freqs), workers=workers, quiet=args.json)
        text = timedomain.format_gains
    if args.plot:
        from .timedomainplots import plot_waveforms
        plot_waveforms(rows, args.plot)
    if args.json:
        print(json.dumps({"study": args.study, "rows": rows}))
        return 0
    print(text(rows))
    if args.plot:
        print(f"wrote {args.plot}")
    return 0
