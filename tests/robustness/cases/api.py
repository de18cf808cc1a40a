"""Bad input against Python API arguments."""

from __future__ import annotations

import numpy as np

from tests.robustness.harness import Attempt, Case, edit_csv, registrar, trial


def cases() -> list[Case]:
    """The cases of this artefact, in a fixed order."""
    found: list[Case] = []
    case = registrar(found)


    # --- Python API arguments ----------------------------------------------------------------
    @case("api train", "epochs=0")
    def _(s, d):
        from psmforce.estimators.training.train import train
        return Attempt(call=lambda: train(s.bench, "fcn", d / "m.pt", epochs=0),
                       names=("epochs",))

    @case("api train", "epochs=2.5")
    def _(s, d):
        from psmforce.estimators.training.train import train
        return Attempt(call=lambda: train(s.bench, "fcn", d / "m.pt", epochs=2.5),
                       names=("epochs",))

    @case("api simulate", "scale=-1")
    def _(s, d):
        from psmforce.sim import simulate
        return Attempt(call=lambda: simulate("automated", scale=-1, out=d / "b"),
                       names=("scale",))

    @case("api simulate", "seed=1e23")
    def _(s, d):
        from psmforce.sim import simulate
        return Attempt(call=lambda: simulate("automated", scale=0.005, seed=1e23, out=d / "b"),
                       names=("seed",))

    @case("api simulate", "scale=1e-9: every trial at its minimum length", "HANDLED")
    def _(s, d):
        from psmforce.estimators.data.dataset import load_dataset
        from psmforce.sim import simulate

        def check(summary):
            trials = load_dataset(d / "b").trials
            kinds = {(t.split, t.condition) for t in trials}
            return (len(kinds) == 6 and min(len(t) for t in trials) > 1,
                    f"{len(trials)} readable trials covering {len(kinds)} split x condition, "
                    f"{min(len(t) for t in trials)} samples or more each")
        return Attempt(call=lambda: simulate("automated", scale=1e-9, out=d / "b"), check=check)

    @case("api fit_prior_cli", "a poor fit is saved marked poor_fit", "HANDLED")
    def _(s, d):
        from psmforce.identification import fit_prior_cli
        data = s.copy(d)
        edit_csv(trial(data), lambda f: f.assign(fz=1e6))

        def check(report):
            return (bool(report.get("poor_fit")) and report["model"] is not None,
                    f"saved with poor_fit={report.get('poor_fit')} (test Free fz RMS "
                    f"{report['test_free_metrics']['fz']['rms']:.3g} N)")
        return Attempt(call=lambda: fit_prior_cli(data, d / "p.json"), check=check)

    @case("api PSM", "q of 5 joints")
    def _(s, d):
        from psmforce.robot import PSM
        return Attempt(call=lambda: PSM().spatial_jacobian(np.zeros(5)), names=("q", "6"))

    @case("api PSM", "forward_kinematics of NaN joints")
    def _(s, d):
        from psmforce.robot import PSM
        return Attempt(call=lambda: PSM().forward_kinematics(np.full(6, np.nan)), names=("q",))

    @case("api PSM", "frame 'elbow'")
    def _(s, d):
        from psmforce.robot import PSM
        return Attempt(call=lambda: PSM().forward_kinematics(np.zeros(6), frame="elbow"),
                       names=("elbow", "frame"))

    @case("api PSM", "wrench_from_torques with NaN torques")
    def _(s, d):
        from psmforce.robot import PSM
        q = np.array([0.1, -0.2, 0.12, 0.3, 0.1, -0.1])
        return Attempt(call=lambda: PSM().wrench_from_torques(q, np.full(6, np.nan)),
                       names=("tau", "torque", "NaN", "finite"))
    return found
