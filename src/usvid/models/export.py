"""Export response models to python-control transfer functions.

:func:`to_transfer_function` turns a Nomoto/Norrbin model (or a :class:`VesselModel` holding one)
into a ``control.TransferFunction`` from the propulsion angle delta [rad] to the yaw rate r [rad/s]
(or to the heading psi [rad] with ``output="psi"``), optionally in series with the steering servo.

- Nomoto 1st order (Mu et al. 2018 eq. 35 with alpha = 0): ``r/delta = K / (T s + 1)``.
- Nomoto 2nd order (Mu et al. 2018 eq. 29): ``r/delta = K (1 + T3 s) / ((1 + T1 s)(1 + T2 s))``.
- Norrbin (``T r' + n1 r + n3 r^3 = K delta``), linearised about r = 0: ``K / (T s + n1)``
  (the cubic term has zero slope there).
- Servo (Mu et al. 2018 eq. 11, eq. 12 and section 5.1.3): first order ``1 / (T s + 1)``; second
  order ``gain omega_n^2 / (s^2 + 2 zeta omega_n s + omega_n^2)``; the dead time ``e^{-s delay}`` as
  a Pade approximant of order ``pade_order`` (0 leaves the delay out). Angle and rate limits are
  nonlinear and are not represented.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from usvid.errors import UsvidError
from usvid.models.registry import kind_of


def _scalar(value: Any, name: str) -> float:
    arr = np.asarray(value, dtype=float)
    if arr.size != 1:
        raise UsvidError(f"to_transfer_function: parameter {name} must be a scalar (got shape "
                         f"{arr.shape}); export one member of a batch at a time")
    return float(arr.reshape(()))


def response_polynomials(dynamics: Any) -> tuple[list[float], list[float]]:
    """Numerator and denominator (highest power first) of r/delta for a response model (the
    kind's ``transfer``: Nomoto 1st/2nd order, Norrbin linearised; units K [1/s], T's [s])."""
    kind = kind_of(dynamics)
    if kind.transfer is None:
        raise UsvidError(
            f"to_transfer_function: model kind {kind.name!r} has no linear yaw response "
            "(nomoto1, nomoto2 or norrbin; linearise a 3-DOF model by identifying one)")
    for name, v in dynamics.values().items():
        if not hasattr(v, "thrust") and v is not None:
            _scalar(v, name)
    return kind.transfer(dynamics)


def servo_transfer_function(servo: Any, pade_order: int = 2) -> Any:
    """The servo as a ``control.TransferFunction`` delta/delta_cmd (limits not represented)."""
    import control

    kind = getattr(servo, "kind", "ideal")
    if kind == "ideal":
        return control.tf([1.0], [1.0])
    if kind == "first_order":
        T = float(servo.T)
        return control.tf([1.0], [T, 1.0]) if T > 0 else control.tf([1.0], [1.0])
    if kind == "second_order":
        w, z, g = float(servo.omega_n), float(servo.zeta), float(servo.gain)
        sys = control.tf([g * w * w], [1.0, 2.0 * z * w, w * w])
        delay = float(getattr(servo, "delay", 0.0))
        if delay > 0 and pade_order > 0:
            num, den = control.pade(delay, pade_order)
            sys = sys * control.tf(num, den)
        return sys
    raise UsvidError(f"to_transfer_function: unknown servo kind {kind!r}")


def to_transfer_function(model: Any, *, output: str = "r", include_servo: bool = False,
                         pade_order: int = 2) -> Any:
    """A python-control ``TransferFunction`` of a response model.

    Parameters
    ----------
    model : VesselModel or Nomoto1 / Nomoto2 / Norrbin
        The response model (a ``VesselModel`` is unwrapped via ``.dynamics``; its ``.servo`` is
        used when ``include_servo``).
    output : {"r", "psi"}
        ``"r"``: yaw rate [rad/s] per propulsion angle [rad]; ``"psi"``: heading [rad] per
        angle [rad] (an extra integrator 1/s).
    include_servo : bool
        Put the steering servo (commanded -> actual angle) in series, delay as Pade.
    pade_order : int
        Order of the Pade approximant of the servo dead time (0: ignore the delay).
    """
    import control

    dynamics = getattr(model, "dynamics", model)
    num, den = response_polynomials(dynamics)
    sys = control.tf(num, den)
    if output == "psi":
        sys = sys * control.tf([1.0], [1.0, 0.0])
    elif output != "r":
        raise UsvidError(f"to_transfer_function: output must be 'r' or 'psi' (got {output!r})")
    servo = getattr(model, "servo", None) if include_servo else None
    if servo is not None:
        sys = servo_transfer_function(servo, pade_order) * sys
    # label the signals (python-control >= 0.10): input delta or delta_cmd [rad], output r/psi
    tf = control.tf(sys.num, sys.den, inputs="delta_cmd" if servo is not None else "delta",
                    outputs=output, name=f"{getattr(dynamics, 'kind', 'response')}_{output}")
    return tf
