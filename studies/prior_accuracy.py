"""The internal-force prior's held-out accuracy on the simulated bench, and which simulated effect
costs it what (the figures of docs/identification.md, section 2).

For each bench variant (the default bench, then the bench with one joint-effort channel effect of
docs/simulator.md section 8 switched off at a time, then with all four off) the automated protocol
is simulated (``--scale``, ``--seed``), the prior is fitted on the training split, Free trials
only (``fit-prior``'s default) and Free + Traction + Palpation (``--use-loaded``, what the
hybrid's training fits), and scored on the test Free trials, per force axis: RMS of
``reading - prior`` (N), R^2, the reading's std (the RMS a constant at the test mean would
leave), the fz error against the bench's true internal axial force (``sim_internal_fz``, before
the HEX10's own noise and drift), and the fz RMS after the evaluation's start-up tare (each test
recording's first 0.5 s mean of ``reading - prior`` removed). The HEX10 readings are the same in
every variant (the effects switched off act on the joint efforts only), so the rows differ by
what the prior's inputs carry.

With the WPI recordings present (``--wpi``), also the wrist discs' Coulomb levels our arm
identification finds on the real arm (fitted on ``one_results``) and on the default bench replaying
the same trajectory (as ``psmforce.experiments.bench_calibration`` does, noise seed 10): whether the
bench's motor-side friction, which the prior cannot see, is larger than the real arm's. Usage::

    python studies/prior_accuracy.py [--scale 0.05] [--seed 1] [--json PATH] [--wpi DIR]
"""

from __future__ import annotations

import argparse
import dataclasses
import tempfile
import time
from pathlib import Path

import numpy as np

from psmforce.experiments.report import write_json

EFFORT_EFFECTS = ("drive_friction", "coloured_effort_noise", "current_quantisation",
                  "remount_offsets")
"""The joint-effort channel effects of the calibrated bench (docs/simulator.md, section 8);
``drive_friction`` includes the wrist discs' friction with stiction."""
TARE_SAMPLES = 50
"""The evaluation's start-up tare: the first 0.5 s at 100 Hz (psmforce.estimators.evaluation.metrics.BIAS_SECONDS)."""


def _score(prior, frames, psm) -> dict:
    from psmforce.io.recording import HEX10_FORCE

    y = np.concatenate([f[list(HEX10_FORCE)].to_numpy() for f in frames])
    pred = [prior.predict(f, psm)[:, :3] for f in frames]
    y_hat = np.concatenate(pred)
    internal = np.concatenate([f["sim_internal_fz"].to_numpy() for f in frames])
    tared = np.concatenate([
        f["fz"].to_numpy() - p[:, 2] - (f["fz"].to_numpy()[:TARE_SAMPLES]
                                        - p[:TARE_SAMPLES, 2]).mean() for f, p in zip(frames, pred)])
    out = {}
    for k, axis in enumerate(("fx", "fy", "fz")):
        r = y[:, k] - y_hat[:, k]
        out[axis] = {"rms_n": float(np.sqrt(np.mean(r ** 2))), "std_n": float(y[:, k].std()),
                     "r2": float(1.0 - np.mean(r ** 2) / y[:, k].var())}
    out["fz"]["rms_vs_true_internal_n"] = float(np.sqrt(np.mean((y_hat[:, 2] - internal) ** 2)))
    out["fz"]["rms_after_tare_n"] = float(np.sqrt(np.mean(tared ** 2)))
    return out


def run_variant(effects, scale: float, seed: int, workdir: Path) -> dict:
    from psmforce.robot import PSM
    from psmforce.identification.prior import InternalForcePrior
    from psmforce.io.recording import list_recordings, read_recording
    from psmforce.sim import simulate

    simulate("automated", scale=scale, seed=seed, out=workdir, effects=effects)
    recs = list_recordings(workdir)
    psm = PSM()

    def frames(split, conditions):
        return [read_recording(r.path) for r in recs
                if r.split == split and r.condition in conditions]

    test = frames("test", ("Free",))
    out = {}
    for label, conditions in (("free", ("Free",)), ("loaded", ("Free", "Traction", "Palpation"))):
        t0 = time.perf_counter()
        prior = InternalForcePrior.fit(frames("train", conditions), psm=psm)
        out[label] = {"fit_s": round(time.perf_counter() - t0, 2),
                      "solver_status": prior.info["solver_status"],
                      "bounds_hit": prior.info["bounds_hit"],
                      "train_fz_rms_n": prior.info["train_metrics"]["fz"]["rms"],
                      "test_free": _score(prior, test, psm)}
    return out


def disc_coulomb(wpi_dir: Path) -> dict:
    """{"real": (3,), "bench": (3,)} Coulomb levels (Nm) of the three wrist discs identified by
    :func:`psmforce.identification.fit_arm_dynamics` in WPI's recorder coordinates."""
    from psmforce.identification import DynamicsFitOptions, fit_arm_dynamics, wpi
    from psmforce.identification.dynamics_options import SELECTION_CANDIDATES
    from psmforce.io.recording import JOINT_EFFORTS, JOINT_POSITIONS, JOINT_VELOCITIES
    from psmforce.identification.signals import zero_phase_lowpass
    from psmforce.sim import Contact, Effects, InstrumentParams, run_trajectory
    from psmforce.experiments import bench_calibration as calibration

    # the model the bench's disc friction was calibrated with: without the Maxwell-slip terms,
    # whose elements would take part of the level the comparison reads as Coulomb
    options = SELECTION_CANDIDATES["no hysteresis (previous default)"]
    t = wpi.coordinates_to_dvrk_matrix()
    t_inv = np.linalg.inv(t)

    def coulomb(q, dq, tau, rate_hz):
        model = fit_arm_dynamics(q @ t_inv.T, dq @ t_inv.T, tau @ t, sample_rate_hz=rate_hz,
                                 coupling=t, coordinate_names=wpi.MOTOR_COORDINATES,
                                 options=options)
        values = dict(zip(model.linear_parameter_names, model.linear_parameters))
        return [float(values[f"{c}.friction.coulomb"]) for c in wpi.MOTOR_COORDINATES[4:]]

    rec = wpi.load_wpi(wpi_dir / "one_results.csv")
    q, dq, tau = rec.to_dvrk()
    step = int(round(rec.sample_rate_hz / calibration.RATE_HZ))
    q_cmd = zero_phase_lowpass(q, rec.sample_rate_hz, DynamicsFitOptions().cutoff_hz)[::step]
    frame = run_trajectory(q_cmd, 1.0 / calibration.RATE_HZ, Contact(), InstrumentParams(),
                           Effects(), np.random.default_rng([10, 14, 0]), truth=False)
    sim = [frame[list(columns)].to_numpy()
           for columns in (JOINT_POSITIONS, JOINT_VELOCITIES, JOINT_EFFORTS)]
    return {"real": coulomb(q, dq, tau, rec.sample_rate_hz),
            "bench": coulomb(*sim, calibration.RATE_HZ)}


def main() -> dict:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--scale", type=float, default=0.05)
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--json", type=Path)
    ap.add_argument("--wpi", type=Path,
                    default=Path(__file__).resolve().parents[2] / "shared" / "data" / "wpi_psm")
    args = ap.parse_args()
    from psmforce.sim import Effects

    default = Effects()
    variants = {"default bench": default}
    variants.update({f"without {name}": dataclasses.replace(default, **{name: False})
                     for name in EFFORT_EFFECTS})
    variants["without all four"] = dataclasses.replace(
        default, **{name: False for name in EFFORT_EFFECTS})
    result = {"scale": args.scale, "seed": args.seed, "variants": {}}
    print(f"prior on the automated bench, scale {args.scale}, seed {args.seed}: test Free, "
          "RMS of reading - prior (N) / R^2; fz vs true internal; fz after the start-up tare")
    with tempfile.TemporaryDirectory() as tmp:
        for i, (name, effects) in enumerate(variants.items()):
            r = run_variant(effects, args.scale, args.seed, Path(tmp) / str(i))
            result["variants"][name] = r
            for label in ("free", "loaded"):
                s = r[label]["test_free"]
                print(f"  {name:34s} {label:6s} " + "  ".join(
                    f"{a} {s[a]['rms_n']:.3f}/{s[a]['r2']:+.2f}" for a in ("fx", "fy", "fz"))
                    + f"  (fz std {s['fz']['std_n']:.3f}) vs internal "
                      f"{s['fz']['rms_vs_true_internal_n']:.3f} tared "
                      f"{s['fz']['rms_after_tare_n']:.3f}  [{r[label]['solver_status']}, "
                      f"bounds {r[label]['bounds_hit']}]")
    if (args.wpi / "one_results.csv").is_file():
        result["disc_coulomb_nm"] = c = disc_coulomb(args.wpi)
        print("wrist disc Coulomb (Nm) identified, real WPI arm: "
              + " ".join(f"{x:.4f}" for x in c["real"]) + "; bench replaying it: "
              + " ".join(f"{x:.4f}" for x in c["bench"]))
    else:
        print(f"WPI data not found in {args.wpi}: disc friction comparison skipped")
    if args.json:
        write_json(args.json, result)
    return result


if __name__ == "__main__":
    main()
