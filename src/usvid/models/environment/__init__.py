"""The environment a vessel moves in: wind, current and waves (no integration, no files).

:mod:`.wind`: the wind triangle (apparent <-> true wind).
"""
