"""numba's on-disk cache written best effort (usvid.jitcache): a function compiled in a process
that cannot write the cache (here ``ulimit -f``) runs, with one JitCacheWarning; without
usvid.jitcache numba lets the save's OSError escape from the call that compiled."""

from __future__ import annotations

import os
import resource
import subprocess
import sys
from pathlib import Path

SRC = Path(__file__).resolve().parents[1] / "src"

MODULE = """import numba
{extra}

@numba.njit(cache=True)
def f(x):
    return x + 1
"""


def _run(tmp_path: Path, extra: str) -> subprocess.CompletedProcess:
    """``jitmod.f(1)`` compiled in a fresh child whose file-size limit (1 byte) makes numba's
    cache save fail with EFBIG (Python ignores SIGXFSZ)."""
    (tmp_path / "jitmod.py").write_text(MODULE.format(extra=extra))
    env = dict(os.environ, PYTHONPATH=os.pathsep.join([str(tmp_path), str(SRC)]),
               NUMBA_CACHE_DIR=str(tmp_path / "cache"), PYTHONDONTWRITEBYTECODE="1")

    def limit() -> None:
        resource.setrlimit(resource.RLIMIT_FSIZE, (1, resource.getrlimit(resource.RLIMIT_FSIZE)[1]))

    code = "import jitmod; print(jitmod.f(1))"
    return subprocess.run([sys.executable, "-W", "always", "-c", code], env=env,
                          preexec_fn=limit, capture_output=True, text=True, timeout=120)


def test_unwritable_cache_is_a_warning_not_an_error(tmp_path) -> None:
    r = _run(tmp_path, "import usvid.jitcache  # noqa: F401")
    assert r.returncode == 0, r.stderr[-2000:]
    assert r.stdout.strip() == "2"
    assert r.stderr.count("JitCacheWarning") == 1, r.stderr[-2000:]
    assert "compiled code kept in memory only" in r.stderr
    # nothing under a cache file's final name (numba removes its temporary file on error)
    assert not any(p.suffix in (".nbi", ".nbc") for p in (tmp_path / "cache").rglob("*"))


def test_numba_alone_fails_on_an_unwritable_cache(tmp_path) -> None:
    """The behaviour usvid.jitcache exists for (numba 0.59-0.68); if a numba release tolerates
    it, this fails and usvid.jitcache can go."""
    r = _run(tmp_path, "")
    assert r.returncode != 0
    assert "File too large" in r.stderr, r.stderr[-2000:]
