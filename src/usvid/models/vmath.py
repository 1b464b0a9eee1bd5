"""Branch-free elementary functions for numba kernels that LLVM vectorises across lanes.

``math.asin`` and ``math.sqrt`` compile to calls of the C library, which stop LLVM's loop
vectoriser, and ``math.exp`` to a call per lane (numba has no vector math library here). These
are the same functions as straight-line arithmetic (selects instead of branches, square roots,
at most one division): FreeBSD's msun (fdlibm, Sun Microsystems 1993) ``e_asin.c`` (its
coefficients and argument reduction) and ``e_exp.c`` (its argument reduction; e^r of the reduced
argument by its Taylor polynomial, no division). Polynomials are evaluated by Estrin's scheme
(Estrin 1960: pairs ``a + b x``, then combined with x^2, x^4, ...): in the vector step the lanes
wait on the dependency chain, which is log-deep this way instead of as deep as the degree
(Horner's). Accuracy: within 1 ulp (exp) and 2 ulp (asin) of the correctly rounded value on
their domains (tested against ``math`` in tests/test_vmath.py).
"""

from __future__ import annotations

import numba
import numba.extending
import numpy as np
from llvmlite import ir as llvmir

import usvid.jitcache  # noqa: F401 - numba's cache written best effort

_PIO2_HI = 1.57079632679489655800e00
_PIO2_LO = 6.12323399573676603587e-17
_PS0 = 1.66666666666666657415e-01
_PS1 = -3.25565818622400915405e-01
_PS2 = 2.01212532134862925881e-01
_PS3 = -4.00555345006794114027e-02
_PS4 = 7.91534994289814532176e-04
_PS5 = 3.47933107596021167570e-05
_QS1 = -2.40339491173441421878e00
_QS2 = 2.02094576023350569471e00
_QS3 = -6.88283971605453293030e-01
_QS4 = 7.70381505559019352791e-02

_LN2_HI = 6.93147180369123816490e-01
_LN2_LO = 1.90821492927058770002e-10
_INV_LN2 = 1.44269504088896338700e00
#: 1/k!, the Taylor coefficients of e^r (k = 2..13; :func:`exp`)
_E2 = 1.0 / 2.0
_E3 = 1.0 / 6.0
_E4 = 1.0 / 24.0
_E5 = 1.0 / 120.0
_E6 = 1.0 / 720.0
_E7 = 1.0 / 5040.0
_E8 = 1.0 / 40320.0
_E9 = 1.0 / 362880.0
_E10 = 1.0 / 3628800.0
_E11 = 1.0 / 39916800.0
_E12 = 1.0 / 479001600.0
_E13 = 1.0 / 6227020800.0
#: 1.5 * 2**52: the sum of it and an integral float of magnitude < 2**51 holds that integer in
#: the low bits of its representation (the float-to-integer conversion without a conversion
#: instruction, which AVX2 lacks for 64-bit integers).
_MAGIC = 6755399441055744.0


@numba.extending.intrinsic
def _f64_bits(typingctx, x):
    """The IEEE 754 bits of the float64 x as an int64."""
    sig = numba.types.int64(numba.types.float64)

    def codegen(context, builder, signature, args):
        return builder.bitcast(args[0], llvmir.IntType(64))

    return sig, codegen


@numba.extending.intrinsic
def _bits_f64(typingctx, i):
    """The float64 of the IEEE 754 bits i (int64)."""
    sig = numba.types.float64(numba.types.int64)

    def codegen(context, builder, signature, args):
        return builder.bitcast(args[0], llvmir.DoubleType())

    return sig, codegen


@numba.extending.intrinsic
def sqrt(typingctx, x):
    """The square root of the float64 x (NaN for x < 0) as LLVM's ``llvm.sqrt`` intrinsic:
    ``math.sqrt`` compiles to a call of the C library's ``sqrt`` (it may set errno), which LLVM
    does not always turn into the instruction, and a call stops the loop vectoriser."""
    sig = numba.types.float64(numba.types.float64)

    def codegen(context, builder, signature, args):
        fn = builder.module.declare_intrinsic("llvm.sqrt", [llvmir.DoubleType()])
        return builder.call(fn, [args[0]])

    return sig, codegen


@numba.njit(cache=True, inline="always")
def asin(x: float) -> float:
    """arcsin x [rad] for -1 <= x <= 1 (NaN outside): fdlibm's ``__ieee754_asin``.

    ``asin x = x + x R(x^2)`` for |x| < 0.5, ``pi/2 - 2 (s + s R(t))`` with ``t = (1 - |x|)/2``,
    ``s = sqrt t`` (and the sign of x) above, R the same rational function (fdlibm's pS/qS).
    The two cases share one evaluation of R (a select of its argument); the 0.5 <= |x| < 0.975
    case of fdlibm (split s for one more bit) takes the |x| >= 0.975 formula."""
    ax = abs(x)
    big = ax >= 0.5
    t = (1.0 - ax) * 0.5 if big else x * x
    # fdlibm's numerator and denominator by Estrin's scheme (pairs, then powers t^2, t^4)
    # instead of Horner's: the same polynomials, a dependency chain of 3 multiply-adds
    # instead of 6 (the vector step's lanes wait on this chain, not on the arithmetic)
    t2 = t * t
    t4 = t2 * t2
    p = t * ((_PS0 + _PS1 * t) + (_PS2 + _PS3 * t) * t2 + (_PS4 + _PS5 * t) * t4)
    q = (1.0 + _QS1 * t) + (_QS2 + _QS3 * t) * t2 + _QS4 * t4
    w = p / q
    s = sqrt(t)
    hi = _PIO2_HI - (2.0 * (s + s * w) - _PIO2_LO)
    hi = hi if x > 0.0 else -hi
    return hi if big else x + x * w


@numba.njit(cache=True, inline="always")
def exp(x: float) -> float:
    """e^x for -708 <= x <= 709 (clamped to that range; NaN stays NaN), without a division:
    fdlibm's argument reduction (``__ieee754_exp``: ``x = k ln 2 + r``, |r| <= ln 2 / 2, r =
    hi - lo with hi exact), then ``e^r = 1 + (hi - (lo - r^2 P(r)))`` with P the Taylor
    polynomial of ``(e^r - 1 - r) / r^2`` to degree 11 (e^r to degree 13: truncation below
    6e-18 relative for |r| <= ln 2 / 2, 0.05 ulp), evaluated by Estrin's scheme, times 2^k
    formed in the exponent bits. fdlibm's rational form ``1 + 2 r / (R(r) - r)`` needs a
    division on the chain; this one only multiply-adds, 5 deep (within 1 ulp, as fdlibm's:
    tests/test_vmath.py)."""
    x = min(max(x, -708.0), 709.0)
    # k, the nearest integer to x / ln 2, as a float: np.floor compiles to a vector round;
    # math.floor returns an integer, whose conversion (no 64-bit one in AVX2) is done per lane
    kf = np.floor(x * _INV_LN2 + 0.5)
    hi = x - kf * _LN2_HI
    lo = kf * _LN2_LO
    r = hi - lo
    r2 = r * r
    r4 = r2 * r2
    r8 = r4 * r4
    P = (((_E2 + _E3 * r) + (_E4 + _E5 * r) * r2)
         + ((_E6 + _E7 * r) + (_E8 + _E9 * r) * r2) * r4
         + ((_E10 + _E11 * r) + (_E12 + _E13 * r) * r2) * r8)
    y = 1.0 + (hi - (lo - r2 * P))
    k = _f64_bits(kf + _MAGIC) - _f64_bits(_MAGIC)  # kf as an integer
    return y * _bits_f64((k + 1023) << 52)
