"""usvid.models: model kinds (parameter sets and their one right-hand side), servos, thrust
laws, hull regressions. No integration (see ``usvid.sim``), no files (see ``usvid.io``).

Kinds (:mod:`usvid.models.registry`, one module each in :mod:`usvid.models.kinds`): Nomoto1,
Nomoto2, Norrbin, ThreeDOF, Catamaran; servos (:mod:`.servo`); thrust laws (:mod:`.thrust`);
the complete model (:mod:`.model`): VesselModel.
"""

from usvid.models import registry
from usvid.models.kinds.catamaran import Catamaran
from usvid.models.kinds.nomoto1 import Nomoto1
from usvid.models.kinds.nomoto2 import Nomoto2
from usvid.models.kinds.norrbin import Norrbin
from usvid.models.kinds.threedof import MU2018_EQ37, ThreeDOF
from usvid.models.model import VesselModel
from usvid.models.registry import get as get_kind
from usvid.models.registry import names as kind_names
from usvid.models.servo import FirstOrderServo, IdealServo, SecondOrderServo, mu2018_servo

__all__ = [
    "MU2018_EQ37", "Catamaran", "FirstOrderServo", "IdealServo", "Nomoto1", "Nomoto2",
    "Norrbin", "SecondOrderServo", "ThreeDOF", "VesselModel", "get_kind", "kind_names",
    "registry", "mu2018_servo", "mu2018_threedof",
]


def mu2018_threedof(x_l: float = 3.5, **kw: object) -> ThreeDOF:
    """The Lanxin model of Mu et al. 2018, eq. 37 (x_l [m] is not printed; ~half the length)."""
    return ThreeDOF.from_regression(**MU2018_EQ37, x_l=x_l, **kw)
