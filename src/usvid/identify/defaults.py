"""The default identification method of each model kind: the one that predicts best.

Measured on the HSVA KVLCC2 zig-zags with the held-out protocol of the README ("Identification
methods and what they achieved on real data"): trained on 10/05, 15/05 and 20/05 with default
options, validated (:func:`usvid.identify.validation.validate_trial`) on 10/10 P, 10/10 S,
20/10 P and 20/10 S; the score is the mean absolute error of the first and second overshoots,
a model that fails its checks or diverges ranks last. Kinds that cannot be fitted to a rudder
ship's zig-zags (catamaran: twin thrusters) are chosen on the twin-thruster USV logs (identified
from the sine run, the heading RMS of the circle run's first 60 s), threedof on the virtual
campaign of ``usvid demo`` (held-out 20/20 zig-zag; the HSVA spec lacks its propeller
particulars). A module without imports: the CLI's ``--help`` reads it.
"""

#: Kind -> its methods, best first (the default of ``usvid identify --method`` and of
#: ``ModelEstimator(kind)``: the first that applies, the second when the first one's model fails
#: its checks). Mean |error| [deg] of the first two overshoots over the four held-out runs:
#: nomoto1 oe-zigzag 4.51, oe 4.57, ls 4.63, rls 4.63; nomoto2 oe-zigzag 3.86, oe 4.31, rls
#: 4.97, ls 5.70; norrbin oe-zigzag 1.97, oe 3.40, ls 3.88, rls 4.04; mmg oe 0.80, ls 2.23, rls
#: 2.24, oe-zigzag diverges in the 20/10 zig-zags. Twin-thruster sine run -> circle (heading RMS
#: over 60 s [deg]): mmg oe 26.1, ls 46.5, rls 46.5; catamaran oe 291, ls 550, rls 550. Demo
#: campaign, threedof (20/20 first and second overshoot errors [deg]): ls +0.02, -0.33; rls the
#: same; oe -0.32, -0.74 (oe-zigzag: the turning tests hold no zig-zag).
DEFAULT_METHODS: dict[str, tuple[str, ...]] = {
    "nomoto1": ("oe-zigzag", "oe"),
    "nomoto2": ("oe-zigzag", "oe"),
    "norrbin": ("oe-zigzag", "oe"),
    "mmg": ("oe", "ls"),
    "catamaran": ("oe", "ls"),
    "threedof": ("ls", "oe"),
}
