"""numba's on-disk cache written best effort: a compiled function that cannot be saved (disk
full, file-size limit, read-only or foreign cache folder) is kept in memory and the run goes on.

Every usvid module that compiles with ``numba.njit(cache=True)`` imports this module. numba
saves a freshly compiled function to its cache folder (``__pycache__`` beside the source, or
``NUMBA_CACHE_DIR``) inside the call that compiled it, and on Linux lets any ``OSError`` of
that save escape (numba 0.59-0.68, ``numba.core.caching.Cache.save_overload``: it tolerates
only Windows' EACCES). A first run on a full disk or under ``ulimit -f`` then failed in the
middle of an identification with "[Errno 27] File too large" and no file name, although the
compiled code was already in use (numba registers the overload before saving it; its temporary
file is removed on error, so no partial cache file is left).

Here such errors (no space, file too large, quota, read-only file system, permission) are
turned into one :class:`JitCacheWarning` per process; the function is compiled again in the
next process. Any other error of the save propagates unchanged.
"""

from __future__ import annotations

import errno
import functools
import warnings

from numba.core import caching

#: errno values of a cache that cannot be written (the environment, not the code)
UNWRITABLE = frozenset({errno.ENOSPC, errno.EFBIG, errno.EDQUOT, errno.EROFS, errno.EACCES,
                        errno.EPERM})


class JitCacheWarning(RuntimeWarning):
    """numba's on-disk cache could not be written; the compiled code is used from memory."""


_warned = False


def _tolerant(save):
    @functools.wraps(save)
    def save_overload(self, sig, data):
        global _warned
        try:
            return save(self, sig, data)
        except OSError as exc:
            if exc.errno not in UNWRITABLE:
                raise
            if not _warned:
                _warned = True
                where = f" ({exc.filename})" if exc.filename else ""
                warnings.warn(f"numba's compile cache not written{where}: "
                              f"{exc.strerror or exc}; compiled code kept in memory only",
                              JitCacheWarning, stacklevel=2)
            return None

    save_overload.__usvid_tolerant__ = True
    return save_overload


if not getattr(caching.Cache.save_overload, "__usvid_tolerant__", False):
    caching.Cache.save_overload = _tolerant(caching.Cache.save_overload)
