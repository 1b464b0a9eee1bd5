"""usvid.manoeuvres: standard manoeuvres, one definition each.

Layer: above :mod:`usvid.prep`, below :mod:`usvid.sim`.
"""
