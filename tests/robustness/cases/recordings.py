"""Bad input against recordings: damaged files every reader refuses naming them, what the writer refuses, physically impossible values."""

from __future__ import annotations

import shutil

import numpy as np
import pandas as pd

from tests.robustness.harness import (Attempt, Case, RECORDING_DAMAGE, _repeat, _set,
                                      _swap, _time, edit_csv, trial)


def cases() -> list[Case]:
    """The cases of this artefact, in a fixed order."""
    found: list[Case] = []

    # --- recordings: every reader refuses a damaged file naming it --------------------------
    for damage, apply in RECORDING_DAMAGE.items():
        def read(s, d, apply=apply):
            from psmforce.io.recording import read_recording
            path = d / "rec.csv"
            shutil.copy(trial(s.bench), path)
            apply(path)
            return Attempt(call=lambda: read_recording(path), names=(str(path),))
        found.append(Case("api read_recording", damage, "REJECTED", read))

        def train_on(s, d, apply=apply):
            data = s.copy(d)
            bad = trial(data)
            apply(bad)
            return Attempt(argv=["train", "--data", str(data), "--model", "fcn", "--epochs", "1",
                                 "--out", str(d / "m.pt")], names=(str(bad),))
        found.append(Case("cli train: recording", damage, "REJECTED", train_on))

        def evaluate_on(s, d, apply=apply):
            data = s.copy(d)
            bad = trial(data, "test", "Palpation")
            apply(bad)
            return Attempt(argv=["evaluate", str(s.fcn), "--data", str(data),
                                 "--out", str(d / "eval")], names=(str(bad),))
        found.append(Case("cli evaluate: recording", damage, "REJECTED", evaluate_on))

    for damage in ("zero-byte file", "NaN cell", "text cell", "backwards time",
                   "missing column"):
        def wrench_on(s, d, apply=RECORDING_DAMAGE[damage]):
            rec = d / "rec.csv"
            shutil.copy(trial(s.bench), rec)
            apply(rec)
            return Attempt(argv=["wrench", str(rec), "--dynamics", str(s.arm),
                                 "--out", str(d / "w.csv")], names=(str(rec),))
        found.append(Case("cli wrench: recording", damage, "REJECTED", wrench_on))

        def finetune_on(s, d, apply=RECORDING_DAMAGE[damage]):
            data = s.copy(d)
            bad = trial(data)
            apply(bad)
            return Attempt(argv=["finetune", str(s.fcn), "--data", str(data), "--epochs", "1",
                                 "--out", str(d / "t.pt")], names=(str(bad),))
        found.append(Case("cli finetune: recording", damage, "REJECTED", finetune_on))

    for damage in ("zero-byte file", "NaN cell", "text cell", "backwards time"):
        def fit_prior_on(s, d, apply=RECORDING_DAMAGE[damage]):
            data = s.copy(d)
            bad = trial(data)
            apply(bad)
            return Attempt(argv=["fit-prior", "--data", str(data), "--out", str(d / "p.json")],
                           names=(str(bad),))
        found.append(Case("cli fit-prior: recording", damage, "REJECTED", fit_prior_on))

        def convert_on(s, d, apply=RECORDING_DAMAGE[damage]):
            src = d / "export.csv"
            shutil.copy(trial(s.bench), src)
            apply(src)
            return Attempt(argv=["convert", str(src), "--out", str(d / "out.csv")],
                           names=(str(src),))
        found.append(Case("cli convert: CSV export", damage, "REJECTED", convert_on))

    # --- write_recording refuses what read_recording would refuse ---------------------------
    for damage, change in (("NaN cell", _set("yaw_effort", np.nan)),
                           ("inf cell", _set("fz", -np.inf)),
                           ("backwards time", _time(_swap)),
                           ("duplicate time", _time(_repeat)),
                           ("missing column", lambda f: f.drop(columns=["roll_effort"]))):
        def write(s, d, change=change):
            from psmforce.io.recording import write_recording
            frame = change(pd.read_csv(trial(s.bench)))
            path = d / "rec.csv"
            return Attempt(call=lambda: write_recording(frame, path), names=(str(path),))
        found.append(Case("api write_recording", damage, "REJECTED", write))

    # --- physically impossible values ------------------------------------------------------
    for what, column, value in (("insertion 5 m", "insertion_position", 5.0),
                                ("roll 1e30 rad", "roll_position", 1e30),
                                ("fz 1e39 N", "fz", 1e39)):
        def impossible(s, d, column=column, value=value):
            data = s.copy(d)
            bad = trial(data)
            edit_csv(bad, _set(column, value))
            return Attempt(argv=["train", "--data", str(data), "--model", "fcn", "--epochs", "1",
                                 "--out", str(d / "m.pt")], names=(str(bad),))
        found.append(Case("cli train: recording", f"out of range: {what}", "REJECTED",
                          impossible))
    return found
