"""Start-up: the light layers import no heavy library they do not use at import (each checked in
a fresh interpreter, by the modules loaded, never by a timing). The CPU times are in
benchmarks/bench_imports.py."""

from __future__ import annotations

import subprocess
import sys

import pytest

#: The libraries that cost start-up time (CPU at import, measured with ``python -X importtime``:
#: scipy.signal ~0.6 s, pandas ~0.2-0.4 s, numpy ~0.1-0.2 s on the development machine).
HEAVY = ("numpy", "pandas", "scipy.signal", "scipy.ndimage", "scipy.linalg", "scipy.stats",
         "pymap3d", "numba")


def _loaded(module: str) -> set[str]:
    code = (f"import sys, {module}; "
            f"print(' '.join(m for m in {HEAVY!r} if m in sys.modules))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         check=True).stdout
    return set(out.split())


@pytest.mark.parametrize("module", ["usvid.prep", "usvid.prep.filters", "usvid.manoeuvres.detect",
                                    "usvid.manoeuvres.metrics", "usvid.trial"])
def test_prep_and_manoeuvres_load_only_numpy(module):
    assert _loaded(module) == {"numpy"}


def test_the_manoeuvres_package_loads_its_modules_on_first_use():
    """``import usvid.manoeuvres`` loads none of its modules; each public name resolves to its
    definition on first use, and the simulation (which needs only the logics) loads neither the
    detection nor :mod:`usvid.prep`."""
    code = ("import sys, usvid.manoeuvres as m; "
            "assert not [n for n in sys.modules if n.startswith('usvid.manoeuvres.')]; "
            "import usvid.manoeuvres.detect as d, usvid.manoeuvres.metrics as mt; "
            "assert (m.find_execute, m.zigzag_metrics) == (d.find_execute, mt.zigzag_metrics); "
            "assert m.imo is sys.modules['usvid.manoeuvres.imo']; "
            "assert set(m.__all__) <= set(dir(m)); [getattr(m, n) for n in m.__all__]; "
            "import subprocess; out = subprocess.run([sys.executable, '-c', 'import sys, "
            "usvid.sim; print(sorted(n for n in sys.modules if n.startswith((\"usvid.prep\", "
            "\"usvid.manoeuvres.\"))))'], capture_output=True, text=True, check=True).stdout; "
            "assert out.strip() == \"['usvid.manoeuvres.logic']\", out")
    subprocess.run([sys.executable, "-c", code], check=True)
    with pytest.raises(AttributeError, match="no attribute 'nonexistent'"):
        import usvid.manoeuvres

        usvid.manoeuvres.nonexistent  # noqa: B018 - the attribute access is the test


def test_the_model_kinds_load_no_scipy_or_pandas():
    # the package itself loads its kinds on first use (numpy and numba then); a kind module
    # loads the numerics it runs on and nothing heavier
    assert _loaded("usvid.models") <= {"numpy", "numba"}
    assert _loaded("usvid.models.kinds.threedof") == {"numpy", "numba"}


def test_the_command_line_loads_no_numpy():
    """``usvid --help`` imports the CLI and every command's module: none of them loads numpy
    (each command imports its libraries when it runs)."""
    assert _loaded("usvid.cli") == set()


def test_lazy_names_of_prep_resolve_to_their_definitions():
    """The names loaded on first use are the functions of their modules (the public API is
    unchanged); ``prepare`` and ``resample`` are the functions, not the same-named modules."""
    code = ("import usvid.prep as p, usvid.prep.prepare, usvid.prep.resample, "
            "usvid.prep.channel_audit as ca, usvid.prep.merge as mg, "
            "usvid.prep.state_estimation as se; "
            "from usvid.prep import prepare, resample, audit, merge_trials, estimate_states; "
            "assert callable(prepare) and callable(resample); "
            "assert (audit, merge_trials, estimate_states) == "
            "(ca.audit, mg.merge_trials, se.estimate_states); "
            "assert set(p.__all__) <= set(dir(p)); "
            "[getattr(p, n) for n in p.__all__]")
    subprocess.run([sys.executable, "-c", code], check=True)
    with pytest.raises(AttributeError, match="no attribute 'nonexistent'"):
        import usvid.prep

        usvid.prep.nonexistent  # noqa: B018 - the attribute access is the test


def test_the_simulation_package_loads_no_pandas_or_scipy_signal():
    assert _loaded("usvid.sim") == {"numpy", "numba"}


def test_model_files_load_without_pandas_or_the_readers():
    """Loading a model file (``usvid simulate``, ``usvid autopilot``) needs none of the log
    readers: ``usvid.io`` loads them, and pandas, on first use of their names, each name then
    resolving to its definition."""
    assert _loaded("usvid.io.modelfile") <= {"numpy", "numba"}
    code = ("import sys, usvid.io as io, usvid.io.modelfile; "
            "assert 'pandas' not in sys.modules and 'usvid.io.reader' not in sys.modules; "
            "import usvid.io.reader as r, usvid.io.spec as s, usvid.io.writers as w; "
            "assert (io.read_trial, io.FormatSpec, io.write_csv) == "
            "(r.read_trial, s.FormatSpec, w.write_csv); "
            "assert set(io.__all__) <= set(dir(io)); [getattr(io, n) for n in io.__all__]")
    subprocess.run([sys.executable, "-c", code], check=True)
    with pytest.raises(AttributeError, match="no attribute 'nonexistent'"):
        import usvid.io

        usvid.io.nonexistent  # noqa: B018 - the attribute access is the test
