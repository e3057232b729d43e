"""Build the smeha transducer FMU(s) into dist/.

    python build_fmu.py [--fmi 2|3|both] [--out dist] [--no-validate]

All the logic is in :mod:`smeha.fmu_build` (``smeha build`` calls the same
function). Exits non-zero on failure.
"""
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))

from smeha.fmu_build import main  # noqa: E402

if __name__ == "__main__":
    sys.exit(main())
