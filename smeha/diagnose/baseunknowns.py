"""The base unknowns every fit shares: eq 16's loss coefficients and the strain scale.

(K_h, n, K_e, K_ex) of eq 16 and s = K_lambda / K_lambda of Table 2, their bounds and the
scale factors that make them of order 1 in the least-squares fits
(:mod:`smeha.diagnose.fit`, :mod:`smeha.diagnose.linearfit`).
"""
from __future__ import annotations

import numpy as np

__all__ = ["BASE_LOWER", "BASE_UPPER", "base_factor"]

#: Bounds of the base unknowns (K_h, n, K_e, K_ex, s).
BASE_LOWER = (0.0, 1.0, 0.0, 0.0, 0.2)
BASE_UPPER = (np.inf, 3.0, np.inf, np.inf, 5.0)


def base_factor(base0):
    """Scale factors of the base unknowns in the fit (n and s are not scaled)."""
    return np.array([max(abs(base0[0]), 1.0), 1.0, max(abs(base0[2]), 1.0),
                     max(abs(base0[3]), 1.0), 1.0])
