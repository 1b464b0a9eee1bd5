"""The model-kind registry drives the model-file schema, the CLI choices and the README table."""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pytest

from usvid.errors import UsvidError
from usvid.io.modelfile import MODEL_KINDS, model_from_dict, model_to_dict
from usvid.models import VesselModel, registry
from usvid.models.kind import MAX_PARAMS, MAX_STATES, S0

README = Path(__file__).resolve().parents[1] / "README.md"


def test_readme_kind_table_is_the_generated_one():
    text = README.read_text(encoding="utf-8")
    m = re.search(r"<!-- kinds:begin[^>]*-->\n(.*?)\n<!-- kinds:end -->", text, re.S)
    assert m, "README has no generated kind table"
    assert m.group(1) == registry.readme_table()


def test_every_kind_is_in_the_model_file_schema_and_the_cli():
    from usvid.commands.identify import ModelOpt  # the --model help lists the kinds

    help_text = ModelOpt.__metadata__[0].help
    for name in registry.names():
        assert name in MODEL_KINDS
        assert name in help_text


@pytest.mark.parametrize("name", registry.names())
def test_kind_contract(name):
    kind = registry.get(name)
    dyn = kind.dynamics.example()
    # sizes the core relies on
    assert kind.n_states <= MAX_STATES
    assert kind.n_params <= MAX_PARAMS
    assert S0 == 3
    # the parameter set round-trips through the model file
    d = model_to_dict(VesselModel(dyn))
    back = model_from_dict(d)
    assert back.kind == name
    # every declared parameter has a unit and a meaning
    for p in kind.dynamics.param_specs():
        assert p.meaning and isinstance(p.unit, str)
    # the right-hand side is callable from numpy and returns finite values at rest
    u, v, r, dz = kind.derivatives(dyn, np.zeros(kind.n_states), speed=1.0)
    assert np.all(np.isfinite([u, v, r])) and np.all(np.isfinite(dz))


def test_bad_parameters_name_the_field():
    kind = registry.get("nomoto1")
    with pytest.raises(UsvidError, match=r"parameters\.T must be > 0"):
        kind.dynamics(K=0.5, T=-1.0)
    with pytest.raises(UsvidError, match="unknown model kind"):
        registry.get("nomoto3")


def test_kind_names_without_importing_the_kinds():
    """The registry lists the kinds from the kind modules' names without importing them (the
    CLI's --model help uses it), in the display order; importing usvid.models is lazy."""
    import subprocess
    import sys

    code = ("import sys, usvid.models.registry as r; n = r.names(); "
            "print(','.join(n)); print(any(m.startswith('usvid.models.kinds.') for m in "
            "sys.modules), 'numba' in sys.modules)")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         check=True).stdout.split()
    assert tuple(out[0].split(",")) == registry.names() == tuple(registry.kinds())
    assert out[1:] == ["False", "False"]
