"""The experiment plan of ``psmforce reproduce``: what it runs of each model and how it names it.

The model's own contract (how it is built, what it reads, how it is optimised) is its recipe
(:mod:`psmforce.estimators.networks.recipes`); this table holds what belongs to the comparison
instead: the label in tables and figures, the extra variants (ablations), whether it is also trained
on fractions of the training trials (data efficiency), and the seed paper's published figures to
print beside it. A model without an entry (one registered at run time) is run with its name as label
and nothing extra (:func:`plan`).
"""

from __future__ import annotations

from dataclasses import dataclass

ABLATION_GROUPS = ("no_hex10", "no_efforts", "no_positions", "no_velocities",
                   "no_positions_velocities")
"""Input groups of :data:`psmforce.estimators.data.dataset.FEATURE_SETS` left out, one variant each."""


@dataclass(frozen=True)
class Plan:
    """What ``psmforce reproduce`` runs of one model; see the module docstring."""

    label: str
    """The name in tables and figures."""
    ablations: tuple[str, ...] = ()
    """Extra variants: ``"no_prior"`` or input groups of :data:`psmforce.estimators.data.dataset.FEATURE_SETS`."""
    data_efficiency: bool = False
    """Trained on fractions of the training trials too (:data:`psmforce.experiments.reproduce.DATA_FRACTIONS`)."""
    published_nrmse_pct: dict | None = None
    """The seed paper's NRMSE (%) per axis on its automated test set, where it reports one."""


PLAN: dict[str, Plan] = {
    "transformer": Plan("Transformer (paper)", data_efficiency=True,
                        published_nrmse_pct={"Fx": 1.45, "Fy": 1.31, "Fz": 2.26}),  # Table III
    "fcn": Plan("FCN", published_nrmse_pct={"Fx": 1.93, "Fy": 1.59, "Fz": 2.99}),  # Table III
    "lstm": Plan("LSTM (Yang et al.)",
                 published_nrmse_pct={"Fx": 4.04, "Fy": 4.39, "Fz": 4.05}),  # Table III
    "hybrid": Plan("Hybrid (ours)", ablations=("no_prior",) + ABLATION_GROUPS,
                   data_efficiency=True),
    "rocket": Plan("MultiRocket-Hydra"),
    "hybrid_transformer": Plan("Hybrid physics + paper transformer (ours)"),
}
"""Model name (a key of :data:`psmforce.estimators.networks.recipes.RECIPES`) -> its plan."""


def plan(name: str) -> Plan:
    """The plan of model ``name``: its entry in :data:`PLAN`, else its name as label and no
    extra variants."""
    return PLAN.get(name) or Plan(name)
