"""Model selection within one periodic excitation recording: cross-validation by phase.

A first/last split of a periodic recording scores the model on a repeat of what it was fitted
on; holding out phases of the excitation period scores it on states and velocity combinations
the fit never saw. The WPI study chooses the model variant this way
(``psmforce fit-dynamics --format wpi --select``); recordings in our layout use blocked folds
(``recordings.select_options``).
"""

from __future__ import annotations

import time

import numpy as np

from psmforce.identification.dynamics_fit import (check_fit_inputs, condition_signals,
                                                   coupling_and_names, fit_conditioned)
from psmforce.identification.dynamics_options import (N_COORD, SELECTION_CANDIDATES,
                                                       DynamicsFitOptions)
from psmforce.identification.errors import IdentificationInputError
from psmforce.identification.signals import excitation_period


def phase_cross_validation(c, dc, tau_c, *, sample_rate_hz: float, coupling=None,
                           coordinate_names=None,
                           options: DynamicsFitOptions = DynamicsFitOptions(), folds: int = 5,
                           period_samples: int | None = None) -> dict:
    """Cross-validation within one periodic excitation recording, by phase of the period.

    The signals are conditioned once (whole recording); sample i gets the fold
    floor(folds * phase_i), phase_i = ((i mod P) / P), P the excitation period (estimated with
    :func:`signals.excitation_period` unless given). Each fold is held out in turn: the model is
    fitted on the other phases and scored on this one, so every held-out stretch of the trajectory
    (states, velocity combinations) is one the fit never saw - unlike a first/last split of a
    periodic recording, whose last part repeats the first. Returns per-coordinate relative error
    ||tau - tau_hat|| / ||tau|| pooled over the folds, and the solver status of each fit."""
    T, names = coupling_and_names(coupling, coordinate_names)
    c, dc, tau_c = check_fit_inputs(c, dc, tau_c, options, "cross-validation data")
    if period_samples is None:
        period_samples = excitation_period(c, min_lag=int(sample_rate_hz))
        if period_samples is None:
            raise IdentificationInputError("cross-validation data: no excitation period found "
                                           "(the trajectory does not repeat)")
    cf, dcf, ddcf, tauf, zf = condition_signals(c, dc, tau_c, sample_rate_hz, options,
                                                with_states=True)
    phase = ((np.arange(len(cf)) + options.trim) % period_samples) / period_samples
    fold = np.minimum((phase * folds).astype(int), folds - 1)
    sq_err = np.zeros(N_COORD)
    sq_tau = np.zeros(N_COORD)
    status = []
    for k in range(folds):
        fit, held = fold != k, fold == k
        m = fit_conditioned(cf[fit], dcf[fit], ddcf[fit], tauf[fit], T, names, options,
                            sample_rate_hz, "", time.perf_counter(), states=zf[fit])
        sq_err += np.sum((tauf[held] - m.predict_coordinates(cf[held], dcf[held], ddcf[held],
                                                             zf[held])) ** 2, axis=0)
        sq_tau += np.sum(tauf[held] ** 2, axis=0)
        status.append(m.info["solver_status"])
    return {"relative_error": np.sqrt(sq_err / sq_tau).tolist(), "folds": folds,
            "period_samples": int(period_samples), "solver_status": status}


def select_by_phase_cross_validation(c, dc, tau_c, *, sample_rate_hz: float, coupling=None,
                                     coordinate_names=None, candidates=None, folds: int = 5,
                                     period_samples: int | None = None) -> tuple[str, dict]:
    """Model selection on one periodic training recording: :func:`phase_cross_validation` of
    each candidate (default :data:`SELECTION_CANDIDATES`), score = mean over the 7 coordinates
    of the held-out relative error. Returns the best name and every candidate's figures
    (``held_out_percent``, ``mean_percent``, ``solver_status``). Only these arrays are read."""
    candidates = SELECTION_CANDIDATES if candidates is None else candidates
    table = {}
    for name, opts in candidates.items():
        cv = phase_cross_validation(c, dc, tau_c, sample_rate_hz=sample_rate_hz,
                                    coupling=coupling, coordinate_names=coordinate_names,
                                    options=opts, folds=folds, period_samples=period_samples)
        err = 100 * np.asarray(cv["relative_error"])
        table[name] = {"held_out_percent": err.tolist(), "mean_percent": float(err.mean()),
                       "period_samples": cv["period_samples"],
                       "solver_status": cv["solver_status"]}
    return min(table, key=lambda n: table[n]["mean_percent"]), table
