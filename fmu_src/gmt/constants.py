"""Physical constants, SI."""
import math

#: Permeability of free space, [H/m] (eq 3). The pre-2019 exact value; the
#: 2019 SI value differs by 5e-10 relative, far below every other uncertainty.
MU_0 = 4.0e-7 * math.pi
