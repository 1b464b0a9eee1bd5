"""Response (yaw) models: Nomoto 1st and 2nd order and the Norrbin nonlinear model.

Units: K [1/s] (yaw rate per radian of rudder), time constants [s], delta0 [rad] (rudder offset).
Every parameter may be a scalar or an array over a leading batch axis.

Seed 000 prints "K = 0.332 and T = 0.707" for 0.332 r' + r = 0.707 delta. Read as an equation that
is the other way round: the coefficient of r' is the time constant T and the right-hand gain is K.
The consistent reading (also seed 001's order of magnitude) is T = 0.332 s, K = 0.707 1/s.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from usvid.models._validate import check_params

ArrayLike = float | np.ndarray


@dataclass
class Nomoto1:
    """Nomoto 1st order: ``T r' + r = K (delta + delta0)`` (seed 000 eq. 35 with alpha = 0).

    K [1/s], T [s] > 0, delta0 [rad].
    """

    K: ArrayLike
    T: ArrayLike
    delta0: ArrayLike = 0.0

    kind = "nomoto1"

    def __post_init__(self) -> None:
        check_params("parameters", {"K": self.K, "T": self.T, "delta0": self.delta0},
                     positive=("T",))


@dataclass
class Nomoto2:
    """Nomoto 2nd order (seed 000 eq. 29-30, seed 001 eq. 18).

    ``T1 T2 r'' + (T1 + T2) r' + r = K (delta + delta0 + T3 delta')``, i.e.
    ``r/delta = K (1 + T3 s) / ((1 + T1 s)(1 + T2 s))``. K [1/s], T1, T2 [s] > 0, T3 [s].
    """

    K: ArrayLike
    T1: ArrayLike
    T2: ArrayLike
    T3: ArrayLike = 0.0
    delta0: ArrayLike = 0.0

    kind = "nomoto2"

    def __post_init__(self) -> None:
        check_params("parameters",
                     {"K": self.K, "T1": self.T1, "T2": self.T2, "T3": self.T3,
                      "delta0": self.delta0},
                     positive=("T1", "T2"))


@dataclass
class Norrbin:
    """Norrbin nonlinear response: ``T r' + n1 r + n3 r^3 = K (delta + delta0)``.

    Seed 000 eq. 34-35 is the case n1 = 1, n3 = alpha [s^2/rad^2]. n1 < 0 describes a
    course-unstable vessel (its stable turns are held by n3 > 0). K [1/s], T [s] > 0.
    """

    K: ArrayLike
    T: ArrayLike
    n1: ArrayLike = 1.0
    n3: ArrayLike = 0.0
    delta0: ArrayLike = 0.0

    kind = "norrbin"

    def __post_init__(self) -> None:
        check_params("parameters",
                     {"K": self.K, "T": self.T, "n1": self.n1, "n3": self.n3,
                      "delta0": self.delta0},
                     positive=("T",))
