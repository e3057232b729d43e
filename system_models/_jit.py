"""``jitable``: marks a plain-number physics function the compiled kernel may call.

The function stays an ordinary Python function (the readable reference the
rest of the package and the tests call); numba compiles it only when
:mod:`system_models.kernel` calls it from compiled code
(``numba.extending.register_jitable``).
"""
from __future__ import annotations

try:
    from numba.extending import register_jitable as jitable
except ImportError:  # pragma: no cover - numba is a dependency; keep the physics importable
    def jitable(function):
        return function
