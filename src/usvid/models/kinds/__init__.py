"""The model kinds, one module each (found by :mod:`usvid.models.registry`).

Adding a kind: a module here defining ``KIND = ModelKind(...)`` (see :mod:`usvid.models.kind`),
and its tests. Nothing else changes: the model-file schema, the CLI choices, the README table
and the estimators are driven by the registry.
"""
