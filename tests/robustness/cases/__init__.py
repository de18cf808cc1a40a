"""The robustness cases, one module per artefact, each with a ``cases()`` list in a fixed order.

:data:`MODULES` is the order ``python -m tests.robustness`` runs them in; :func:`all_cases` is
every case.
"""

from __future__ import annotations

from importlib import import_module

MODULES = ("recordings", "datasets", "training", "priors", "checkpoints", "bench",
           "bags", "arm_dynamics", "runs", "stream", "api", "export",
           "outputs", "task_cache", "gates",
           "writes", "sizes", "live")
"""Modules of this package, one per artefact."""


def all_cases() -> list:
    """Every case of every module of :data:`MODULES`, in order."""
    return [c for name in MODULES for c in import_module(f"{__name__}.{name}").cases()]
