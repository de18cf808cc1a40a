"""Which bench seeds may support which claim, declared before any of them is run (issue 45).

A seed looked at while something was designed, chosen or calibrated is a design seed: its
results may have steered the choice and cannot confirm it. A published comparison runs on seeds
that nothing was chosen on, named here in advance, so that a rerun cannot pick the seeds that
favour a model. A seed moves to :data:`DESIGN_SEEDS` once a choice is made on it.
"""

from __future__ import annotations

DESIGN_SEEDS = frozenset({0, 1, 2, 3, 11, 12, 13, 18, 21, 22})
"""Seen while designing: 1-3, the learning curve and the hybrid's batches (chosen on their
validation trials, test scores beside them); 0, the simulator's calibration and the port and
plateau studies; 11-13, the other tool instances; 18, the independent rerun; 21-22, the prior's
in-family recovery; 1-2 also the hybrid's variants on the calibrated bench
(``studies/hybrid_calibrated_design.py``)."""

RECIPE_SWAP_SEEDS = (201, 202, 203)
"""The training regimes swapped between models (``studies/recipe_swap.py``): a choice the
published comparison depends on, so it has seeds of its own."""

PRIOR_ABLATION_SEEDS = (301, 302, 303)
"""The prior's ablation rerun with the insertion base kept in both arms
(``studies/prior_ablation.py``): its first run chose the shipped inputs on seeds 1-3, so the
rerun that confirms it has seeds of its own."""

LOAD_PATH_SEEDS = (401, 402, 403)
"""The prior read through the load path (``studies/prior_recovery.py --default-bench
--load-path``): designed on seed 21 (scale 0.1), confirmed on these."""
CAPSTAN_GROWTH_SEEDS = (404, 405)
"""The law's capstan growing with |wrist pitch| and |roll| (``capstan_pitch_gain``,
``capstan_roll_gain``), read through the load path: proposed after the constant capstan missed on
21 and 401-403, which are then no longer blind to it; these are."""
ATI_FREE_IDENTIFICATION_SEEDS = (431, 432, 433)
"""The instrument identified without an ATI through the load path
(``studies/ati_free_identification.py``): tried on seed 201's ATI-free recordings, confirmed on
these."""
ATI_FREE_READING_SEEDS = (434, 435, 436)
"""Fresh seeds for the load path as read since the closed jaw, the wrist's sag, the pins and the
path tension as pretension (docs/ati_free.md section 4.1), all proposed after seeing
``ATI_FREE_IDENTIFICATION_SEEDS``: declared before any run on them."""
COMPARISON_SEEDS = {0.1: (101, 102, 103, 104, 105), 0.25: (101, 102, 103, 104, 105),
                    1.0: (101, 102, 103)}
"""Per scale, the seeds of the published comparison (at least 5 at 0.1 and 0.25, 3 at the
paper's budget)."""
WIDE_HYBRID_SEEDS = {0.1: (111, 112, 113, 114, 115)}
"""The hybrid at the paper transformer's width against every model, on seeds of its own: the
width was carried by the rule of ``studies/hybrid_calibrated_design.py`` on design seeds 1 and 2,
after the comparison's seeds had shown the lateral deficit, so those cannot confirm it. Declared
before any run on them. Also the seeds of the second candidate of ``studies/hybrid_wide_confirm.py``
(the hybrid's physics read by the paper's transformer, stop 65): nothing about it was chosen on
them, and the hybrid as shipped and every model there serve both candidates. That rule chose the
shipped model on these seeds, so they cannot confirm it: its figures on fresh seeds are the
comparison's (:data:`COMPARISON_SEEDS`), where it was entered after the choice."""


def check_fresh(seeds, purpose: str) -> None:
    """Refuse design seeds for a claim (``purpose`` names it in the message)."""
    used = sorted(set(seeds) & DESIGN_SEEDS)
    if used:
        raise ValueError(f"{purpose}: seed(s) {used} were used while designing; a published "
                         f"figure needs fresh seeds (psmforce/experiments/seeds.py)")
