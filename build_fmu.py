"""Build the smeha transducer FMU(s) into dist/ of the source tree.

    python build_fmu.py [--fmi 2|3|both] [--out DIR] [--no-validate]

The same command as ``smeha build`` (its options: ``smeha build --help``), for a
checkout where the package is not installed; the logic is in :mod:`smeha.fmu_build`.
Exits non-zero on failure (2 for bad options).
"""
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))

from smeha.fmu_build import main  # noqa: E402

if __name__ == "__main__":
    sys.exit(main())
