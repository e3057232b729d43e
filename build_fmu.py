"""Build the smeha transducer FMU(s) into dist/ of the source tree.

    python build_fmu.py [--fmi 2|3|both] [--out DIR] [--no-validate]

The same command as ``smeha build`` (its options: ``smeha build --help``), for a
checkout where the package is not installed; the logic is in :mod:`smeha.fmu.build`, the
command line in :mod:`smeha.cli`.
Exits non-zero on failure (2 for bad options).
"""
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))


def main(argv=None) -> int:
    """``smeha build`` with ``argv`` (default: this script's arguments)."""
    from smeha.cli import main as cli_main
    return cli_main(["build", *(sys.argv[1:] if argv is None else argv)])


if __name__ == "__main__":
    sys.exit(main())
