"""What ``psmforce fit-dynamics`` runs: fit the arm on one data format, gate poor fits, write the
report and the model.

The project's acceptance figure here is :data:`POOR_FIT_RELATIVE_ERROR_PERCENT`; the WPI report
also compares with the published figures (:mod:`.wpi_report`).
"""

from __future__ import annotations

from psmforce.core.files import write_json_atomic
from psmforce.identification.dynamics_options import DynamicsFitOptions
from psmforce.identification.errors import IdentificationInputError
from psmforce.identification.recordings import fit_recordings_report
from psmforce.identification.wpi_report import fit_wpi_report

POOR_FIT_RELATIVE_ERROR_PERCENT = 50.0
"""A dynamics fit whose relative torque error exceeds this on every coordinate (held-out where
there are test recordings, else training) is a poor fit, saved only on request
(``accept_poor_fit``; ``--accept-poor-fit``): it explains less than half of the torque even where
it does best (100 % is predicting zero). Every coordinate, not any: one that carries almost no
torque has a large relative error that means little (docs/identification.md). Measured: the real
WPI arm's best coordinate 9.5 % on its test file (``results/benchmarks/identification.json``), the
simulated bench's insertion below 10 % (tests/io/test_own_data.py); 3000 x 21 random numbers in the
WPI layout 97-101 % on every coordinate."""


def fit_dynamics_cli(train=None, test=None, fmt: str = "csv", json_out=None, model_out=None, *,
                     data=None, select: bool = False, folds: int = 5,
                     options: DynamicsFitOptions | None = None, gravity=None,
                     accept_poor_fit: bool = True) -> dict:
    """What ``psmforce fit-dynamics`` runs: fit, evaluate, write the report JSON (and the model
    JSON if converged); returns the report.

    ``fmt="csv"`` (default): recordings in our layout, ``data`` = a dataset folder (train split
    fits, test split scores), a folder of recordings or one recording; ``test`` optionally
    replaces the dataset's test split; ``select=True`` picks the model variant by blocked
    ``folds``-fold cross-validation on the training recordings only
    (:mod:`psmforce.identification.recordings`). ``fmt="wpi"``: ``train`` / ``test`` are WPI
    files, scored by the published protocol; ``select=True`` picks the variant by phase
    cross-validation on the training file only (:func:`.wpi_report.fit_wpi_report`).
    ``options`` default: :class:`DynamicsFitOptions`; ``gravity`` (3,) m/s^2 in the base frame,
    where the arm's mounting is known (csv only; default identified). The report's ``poor_fit``:
    the relative error exceeds :data:`POOR_FIT_RELATIVE_ERROR_PERCENT` on every coordinate;
    ``accept_poor_fit=False`` (the CLI's default) then saves no model and says why in
    ``model_not_saved_reason``.
    """
    if fmt == "csv":
        if data is None or train is not None:
            raise IdentificationInputError("fit-dynamics on our layout takes the recordings as "
                                           "data=DIR|FILE (--data), not train")
        model, extra = fit_recordings_report(data, test=test, select=select, folds=folds,
                                             options=options, gravity=gravity)
        report = {**extra, **model.fit_summary()}
    elif fmt == "wpi":
        if train is None or data is not None or gravity is not None:
            raise IdentificationInputError("fit-dynamics on WPI files takes train=FILE (--train) "
                                           "and optionally test=FILE; no data or gravity (the "
                                           "published protocol identifies it)")
        model, report = fit_wpi_report(train, test, select=select, folds=folds, options=options)
    else:
        raise IdentificationInputError(
            f"unknown dynamics data format {fmt!r}; supported: 'csv' (our layout), 'wpi'")
    errors = report.get("test_relative_error_percent", report["train_relative_error_percent"])
    best = min(errors)
    report["poor_fit"] = not best <= POOR_FIT_RELATIVE_ERROR_PERCENT  # NaN is poor too
    report["poor_fit_threshold_relative_error_percent"] = POOR_FIT_RELATIVE_ERROR_PERCENT
    if model_out is not None and not model.converged:
        report["model"] = None
        report["model_not_saved_reason"] = f"fit did not converge ({model.info['solver_status']})"
    elif model_out is not None and report["poor_fit"] and not accept_poor_fit:
        report["model"] = None
        report["model_not_saved_reason"] = (
            f"poor fit: relative torque error {best:.3g} % or more on every coordinate "
            f"(> {POOR_FIT_RELATIVE_ERROR_PERCENT:g} %)")
    elif model_out is not None:
        model.save(model_out)
        report["model"] = str(model_out)
    if json_out is not None:
        write_json_atomic(json_out, report)
    return report
