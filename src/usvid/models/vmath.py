"""Branch-free elementary functions for numba kernels that LLVM vectorises across lanes.

``math.asin`` and ``math.sqrt`` compile to calls of the C library, which stop LLVM's loop
vectoriser, and ``math.exp`` to a call per lane (numba has no vector math library here). These
are the same functions as straight-line arithmetic (selects instead of branches, square roots,
one division): FreeBSD's msun (fdlibm, Sun Microsystems 1993) ``e_asin.c`` and ``e_exp.c``, with
their coefficients and argument reductions. Accuracy: within 1 ulp (exp) and 2 ulp (asin) of
the correctly rounded value on their domains (tested against ``math`` in tests/test_vmath.py).
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
_P1 = 1.66666666666666019037e-01
_P2 = -2.77777777770155933842e-03
_P3 = 6.61375632143793436117e-05
_P4 = -1.65339022054652515390e-06
_P5 = 4.13813679705723846039e-08
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
    p = t * (_PS0 + t * (_PS1 + t * (_PS2 + t * (_PS3 + t * (_PS4 + t * _PS5)))))
    q = 1.0 + t * (_QS1 + t * (_QS2 + t * (_QS3 + t * _QS4)))
    w = p / q
    s = sqrt(t)
    hi = _PIO2_HI - (2.0 * (s + s * w) - _PIO2_LO)
    hi = hi if x > 0.0 else -hi
    return hi if big else x + x * w


@numba.njit(cache=True, inline="always")
def exp(x: float) -> float:
    """e^x for -708 <= x <= 709 (clamped to that range; NaN stays NaN): fdlibm's
    ``__ieee754_exp``: ``x = k ln 2 + r``, |r| <= ln 2 / 2, ``e^r = 1 + 2 r / (R(r) - r)`` by
    the Remez polynomial of fdlibm, times 2^k formed in the exponent bits."""
    x = min(max(x, -708.0), 709.0)
    # k, the nearest integer to x / ln 2, as a float: np.floor compiles to a vector round;
    # math.floor returns an integer, whose conversion (no 64-bit one in AVX2) is done per lane
    kf = np.floor(x * _INV_LN2 + 0.5)
    hi = x - kf * _LN2_HI
    lo = kf * _LN2_LO
    r = hi - lo
    t = r * r
    c = r - t * (_P1 + t * (_P2 + t * (_P3 + t * (_P4 + t * _P5))))
    y = 1.0 - ((lo - (r * c) / (2.0 - c)) - hi)
    k = _f64_bits(kf + _MAGIC) - _f64_bits(_MAGIC)  # kf as an integer
    return y * _bits_f64((k + 1023) << 52)
