"""usvid.models: parameter dataclasses and vectorised dynamics ``f(state, inputs)``.

Response models (:mod:`.response`): Nomoto1, Nomoto2, Norrbin; servos (:mod:`.servo`):
IdealServo, FirstOrderServo, SecondOrderServo; 3-DOF vector thruster (:mod:`.threedof`):
ThreeDOF; twin-thruster catamaran (:mod:`.catamaran`): Catamaran; thrust laws (:mod:`.thrust`);
the complete model (:mod:`.model`): VesselModel. No integration here (see ``usvid.sim``).
"""

from usvid.models.catamaran import Catamaran, catamaran_f
from usvid.models.model import KINDS, VesselModel
from usvid.models.response import Nomoto1, Nomoto2, Norrbin, nomoto1_f, nomoto2_f, norrbin_f
from usvid.models.servo import (
    FirstOrderServo,
    IdealServo,
    SecondOrderServo,
    first_order_servo_f,
    second_order_servo_f,
    seed000_servo,
)
from usvid.models.threedof import (
    SEED000_EQ37,
    ThreeDOF,
    seed000_threedof,
    threedof_f,
    threedof_f_tau,
    vector_thrust_tau,
)

__all__ = [
    "KINDS", "SEED000_EQ37", "Catamaran", "FirstOrderServo", "IdealServo", "Nomoto1", "Nomoto2",
    "Norrbin", "SecondOrderServo", "ThreeDOF", "VesselModel", "catamaran_f",
    "first_order_servo_f", "nomoto1_f", "nomoto2_f", "norrbin_f", "second_order_servo_f",
    "seed000_servo", "seed000_threedof", "threedof_f", "threedof_f_tau", "vector_thrust_tau",
]
