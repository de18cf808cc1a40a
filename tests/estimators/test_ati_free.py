"""Calibration without an ATI: known-load targets (m g in the HEX10 frame), their metadata
checks, the ATI-free bench generator and the CLI's guard on --known-loads."""

from __future__ import annotations

import dataclasses
import json

import numpy as np
import pandas as pd
import pytest

from psmforce.estimators.data.dataset import Dataset, Trial, load_dataset
from psmforce.estimators.training.ati_free import (KNOWN_LOAD_CONDITION, KNOWN_LOAD_FIELD,
                                                   CalibrationError, known_load_force_hex10,
                                                   known_load_trials)
from psmforce.io.recording import JOINT_POSITIONS, TARGETS
from psmforce.robot.kinematics import default_psm
from psmforce.sim.bench import Contact, run_trajectory
from psmforce.sim.params import Effects, InstrumentParams

POSE = np.array([0.3, 0.2, 0.15, 0.4, 0.7, -0.3, 0.0])


def _hold(mass_kg: float, effects: Effects | None = None, n: int = 200) -> pd.DataFrame:
    """A weight hung at the tip of a tilted arm with a bent wrist, held still (the bench)."""
    effects = effects or dataclasses.replace(Effects(), sensor_noise=False,
                                             encoder_quantisation=False)
    return run_trajectory(np.repeat(POSE[None], n, 0), 0.01,
                          Contact(kind="weight", mass_kg=mass_kg), InstrumentParams(), effects,
                          np.random.default_rng(0))


def test_known_load_force_is_the_weight_in_the_hex10_frame():
    frame = _hold(0.05)
    q = frame[list(JOINT_POSITIONS)].to_numpy()
    force = known_load_force_hex10(q, 0.05)
    # the bench's own force on the tool, through its ATI target (paper eq. 4, noise off)
    np.testing.assert_allclose(force, frame[list(TARGETS)].to_numpy(), atol=2e-3)
    # the same weight by hand: R_PSM_HEX10(q)^T (0, 0, -m g)
    r = default_psm().rotation(q[:1], "hex10")[0]
    np.testing.assert_allclose(force[0], r.T @ np.array([0.0, 0.0, -0.05 * 9.81]), atol=1e-9)
    assert np.linalg.norm(force[0]) == pytest.approx(0.05 * 9.81)
    assert np.linalg.norm(force[0, :2]) > 0.05 and abs(force[0, 2]) > 0.05  # across and along


def _loads(root, entries: list[dict], frame: pd.DataFrame, metadata: dict | None = None):
    trials = [Trial(f"train/KnownLoad/l{k}.csv", e.pop("condition", KNOWN_LOAD_CONDITION),
                    e.pop("split", "train"), frame.copy(), e) for k, e in enumerate(entries)]
    return Dataset(root, trials, metadata or {})


def test_known_load_trials_set_the_targets_and_keep_the_mass(tmp_path):
    frame = _hold(0.02).drop(columns=list(TARGETS))
    chosen = known_load_trials(_loads(tmp_path, [{KNOWN_LOAD_FIELD: 0.02}], frame))
    expected = known_load_force_hex10(frame[list(JOINT_POSITIONS)].to_numpy(), 0.02)
    np.testing.assert_allclose(chosen[0].matrix(TARGETS, np.float64), expected)


@pytest.mark.parametrize("entry, message", [
    ({}, "no 'known_load_kg'"),
    ({KNOWN_LOAD_FIELD: "50 g"}, "must be a number"),
    ({KNOWN_LOAD_FIELD: True}, "must be a number"),
    ({KNOWN_LOAD_FIELD: float("nan")}, "must be finite"),
    ({KNOWN_LOAD_FIELD: float("inf")}, "must be finite"),
    ({KNOWN_LOAD_FIELD: -0.05}, "must be > 0 kg"),
    ({KNOWN_LOAD_FIELD: 0.0}, "must be > 0 kg"),
    ({KNOWN_LOAD_FIELD: 0.05, "condition": "Free"}, "train/KnownLoad recordings only"),
])
def test_bad_known_load_metadata_is_refused_naming_the_file(tmp_path, entry, message):
    frame = _hold(0.05).drop(columns=list(TARGETS))
    with pytest.raises(CalibrationError, match=message) as err:
        known_load_trials(_loads(tmp_path, [entry], frame))
    assert "l0.csv" in str(err.value)


def test_known_loads_refuse_an_ati_that_disagrees_and_a_tilted_base(tmp_path):
    frame = _hold(0.2)   # its ATI reads 0.2 kg
    with pytest.raises(CalibrationError, match=r"l0.csv: declared a hung 0.05 kg, but its ATI "
                                               r"differs from that weight by 1\.\d\d N"):
        known_load_trials(_loads(tmp_path, [{KNOWN_LOAD_FIELD: 0.05}], frame))
    assert len(known_load_trials(_loads(tmp_path, [{KNOWN_LOAD_FIELD: 0.2}], frame))) == 1
    with pytest.raises(CalibrationError, match="not the upright base"):
        known_load_trials(_loads(tmp_path, [{KNOWN_LOAD_FIELD: 0.2}], frame,
                                 {"gravity_base": [0.0, 9.81, 0.0]}))


def test_the_generator_writes_datasets_calibrate_reads(tmp_path):
    from psmforce.estimators.training.ati_free import free_space_trials
    from psmforce.sim.ati_free import (FREE_SPACE, KNOWN_LOADS, excitation_chunks,
                                       simulate_ati_free)
    from psmforce.sim.ati_free import KNOWN_LOAD_CONDITION as SIM_CONDITION
    assert SIM_CONDITION == KNOWN_LOAD_CONDITION
    assert excitation_chunks(7000, 30.0) == [(0, 3000), (3000, 7000)]
    assert excitation_chunks(8000, 30.0) == [(0, 3000), (3000, 6000), (6000, 8000)]
    exc = np.repeat(POSE[None], 500, 0)
    exc[:, 6] = 0.3
    summary = simulate_ati_free(tmp_path / "g", seed=5, scale=0.01, free_minutes=0.2,
                                excitation_q=exc, weight_poses={"bent": POSE},
                                masses_kg=(0.02, 0.05), hold_s=2.0, tool_seed=7)
    assert summary["minutes"]["paper_free"] == pytest.approx(0.2)
    free = load_dataset(tmp_path / "g" / FREE_SPACE, require_targets=False)
    assert not set(TARGETS) & set(free.trials[0].frame.columns)      # no ATI in the lab
    kinds = [t.params["kind"] for t in free.trials]
    assert kinds == sorted(kinds, key=["paper_free", "excitation"].index)  # paper motion first
    chosen = free_space_trials(free, 0.2 + 1e-6)
    assert {t.params["kind"] for t in chosen} == {"paper_free"}
    loads = load_dataset(tmp_path / "g" / KNOWN_LOADS, require_targets=False)
    assert [t.params[KNOWN_LOAD_FIELD] for t in loads.trials] == [0.02, 0.05]
    meta = json.loads((tmp_path / "g" / KNOWN_LOADS / "metadata.json").read_text())
    assert meta["tool"] == {"seed": 7, "spread": 1.0}
    targets = known_load_trials(loads)[1].matrix(TARGETS, np.float64)
    assert np.linalg.norm(targets, axis=1) == pytest.approx(0.05 * 9.81)


def test_approached_holds_move_into_their_pose_from_alternate_sides(tmp_path):
    """``approach_rad``: each hold's recording starts with the wrist beyond the pose and moves
    into it, from one side at one mass and from the other at the next (each pose thus
    approached both ways); the folder says so. Hung from rest, a hold never moves."""
    from psmforce.sim.ati_free import KNOWN_LOADS, simulate_ati_free
    from psmforce.sim.excitation import APPROACH_RAD
    wrist = ["wrist_pitch_position", "wrist_yaw_position"]
    for approach in (0.0, APPROACH_RAD):
        out = tmp_path / f"g{approach:g}"
        simulate_ati_free(out, seed=5, scale=0.01, free_minutes=0.2,
                          weight_poses={"bent": POSE, "other": POSE * [1, 1, 1, 1, -1, -1, 1]},
                          masses_kg=(0.02, 0.05), hold_s=2.0, approach_rad=approach)
        holds = load_dataset(out / KNOWN_LOADS, require_targets=False).trials
        start = np.array([t.frame[wrist].to_numpy()[0] for t in holds])
        end = np.array([t.frame[wrist].to_numpy()[-1] for t in holds])
        posed = np.array([POSE[[4, 5]], -POSE[[4, 5]]] * 2)
        meta = json.loads((out / KNOWN_LOADS / "metadata.json").read_text())
        if approach == 0.0:
            assert "approach_rad" not in meta
            np.testing.assert_allclose(start, end, atol=0.01)      # the encoders' noise only
            continue
        assert meta["approach_rad"] == APPROACH_RAD
        np.testing.assert_allclose(end, posed, atol=0.02)
        sides = np.sign(start - posed)[:, 0]
        assert sides.tolist() == [1, -1, -1, 1]    # per (mass, pose): each pose both ways


def test_cli_refuses_known_loads_without_free_space(tmp_path, capsys):
    from psmforce.cli.main import main
    (tmp_path / "loads").mkdir()
    argv = ["calibrate", str(tmp_path / "m.pt"), "--data", str(tmp_path), "--out",
            str(tmp_path / "o.pt"), "--known-loads", str(tmp_path / "loads")]
    assert main(argv) == 2
    assert "--known-loads: only with --free-space" in capsys.readouterr().err
    assert main(argv[:-1] + [str(tmp_path / "none"), "--free-space"]) == 2
    assert "is not a dataset folder" in capsys.readouterr().err
    # an output inside the known-loads folder is refused before any work
    (tmp_path / "loads" / "metadata.json").write_text("{}")
    assert main(argv[:4] + ["--out", str(tmp_path / "loads" / "metadata.json"),
                            "--known-loads", str(tmp_path / "loads"), "--free-space"]) == 2
    assert "loads" in capsys.readouterr().err


def test_cli_names_what_the_free_space_recordings_could_not_pin_down(tmp_path, capsys,
                                                                      monkeypatch):
    """docs/ati_free.md section 5, step 6: the command says which prior parameters it held at
    the checkpoint's values, not only the provenance."""
    from psmforce.cli.main import main
    from psmforce.estimators.training import calibrate as calibration
    record = {"trials": [{}], "minutes_used": 3.0, "known_loads_dir": None,
              "minutes_by_condition": {"Free": 3.0, "Traction": 0.0, "KnownLoad": 0.0},
              "epochs_run": 4, "stopped_by": "patience",
              "prior_refit": {"held_from_checkpoint": {"twist_gain": 0.03, "cable_radius": 1e-4}}}
    monkeypatch.setattr(calibration, "calibrate", lambda *a, **k: {"calibration": record})
    (tmp_path / "data").mkdir()
    argv = ["calibrate", str(tmp_path / "m.pt"), "--data", str(tmp_path / "data"), "--out",
            str(tmp_path / "o.pt"), "--free-space"]
    assert main(argv) == 0
    out = capsys.readouterr().out
    assert "held at the checkpoint's values: cable_radius, twist_gain" in out
    record["prior_refit"]["held_from_checkpoint"] = {}
    assert main(argv) == 0 and "held at" not in capsys.readouterr().out
    # with known loads, the instrument identified through the load path: its verdict line
    record["instrument_identification"] = {"verdict": "identified (free, 3 SE within 10%): "
                                                      "cable_radius; fixed at design values"}
    assert main(argv) == 0
    assert "instrument (load path): identified (free, 3 SE within 10%): cable_radius" in (
        capsys.readouterr().out)
    # --no-finetune reaches the library and the line says the network was kept
    asked = {}
    monkeypatch.setattr(calibration, "calibrate",
                        lambda *a, **k: asked.update(k) or {"calibration": record})
    record["finetuned"] = False
    assert main(argv + ["--no-finetune"]) == 0 and asked["finetune"] is False
    assert "the network kept as trained (not finetuned)" in capsys.readouterr().out
    # --network-prior trained reaches the library and the last line says what the network reads
    record["physics_only_axes"] = {"axes": ["Fx", "Fy"], "rule": "by hand", "why": {}}
    assert main(argv + ["--no-finetune", "--network-off", "Fx", "Fy", "--network-prior",
                        "trained"]) == 0
    assert asked["network_prior"] == "trained" and asked["network_off"] == ("Fx", "Fy")
    assert "the prior alone answers Fx, Fy; the network reads the prior it was trained with" \
        in capsys.readouterr().out
    assert main(argv) == 0 and asked["network_prior"] == "calibrated"
    capsys.readouterr()


@pytest.mark.slow
def test_known_loads_identify_the_instrument_through_the_load_path(tmp_path):
    """calibrate's instrument identification (with --known-loads): free space (0 N) and weights
    in the sixteen paired poses read through the load path; its all-free round finds the nominal
    tool's pretension, pulley and cable radii within 10 %, where the efforts' reading of the
    same recordings (the estimator's prior) puts the pretension far off."""
    from psmforce.cli.excitation import WEIGHT_WRIST_POSES_PAIRED, weight_poses
    from psmforce.estimators.training.calibrate import identify_instrument, instrument_report
    from psmforce.experiments.prior_recovery import default_bench_truth
    from psmforce.identification.prior import NAMES, InternalForcePrior
    from psmforce.sim.ati_free import FREE_SPACE, KNOWN_LOADS, simulate_ati_free
    simulate_ati_free(tmp_path / "g", seed=5, scale=0.01, free_minutes=0.3,
                      weight_poses=weight_poses(WEIGHT_WRIST_POSES_PAIRED), masses_kg=(0.1, 0.2),
                      hold_s=3.0)
    from psmforce.estimators.training.ati_free import free_space_trials
    trials = (free_space_trials(load_dataset(tmp_path / "g" / FREE_SPACE,
                                             require_targets=False), 0.3)
              + known_load_trials(load_dataset(tmp_path / "g" / KNOWN_LOADS,
                                               require_targets=False)))
    prior = identify_instrument(trials)
    truth = default_bench_truth()
    # the final fit sags the wrist with its own values, not the design's, and where the passes
    # converged, the sag it took is the one it gives; read back over its own recordings, the law
    # gives its fit's figures only when sagged as it was fitted
    from psmforce.identification.load_path import WristCompliance
    from psmforce.identification.prior_selection import (SAG_TOLERANCE, _sag_change,
                                                         fitted_compliance)
    sag = prior.info["selection"]["sag"]
    assert prior.wrist_compliance == WristCompliance.from_dict(sag["compliance"])
    assert prior.wrist_compliance != WristCompliance.design() and len(sag["passes"]) > 1
    assert sag["converged"] == (_sag_change(prior.wrist_compliance, fitted_compliance(prior))
                                < SAG_TOLERANCE)
    again, stored = prior.fit_metrics([t.frame for t in trials]), prior.info["train_metrics"]
    assert again["fz"]["rms"] == pytest.approx(stored["fz"]["rms"], rel=1e-9)
    first = prior.info["selection"]["rounds"][0]["parameters"]
    for name in ("pretension_total", "pulley_radius_pitch", "pulley_radius_blade",
                 "cable_radius"):
        assert abs(first[name] / truth[name] - 1) < 0.1, (name, first[name], truth[name])
    assert prior.inputs == "load_path"
    efforts = InternalForcePrior.fit([t.frame for t in trials], report=False)
    assert abs(efforts.params[NAMES.index("pretension_total")] / truth["pretension_total"]
               - 1) > 0.5
    report = instrument_report(prior)
    assert list(report["parameters"]) == list(NAMES) and report["verdict"] == prior.info[
        "verdict"]
    assert set(report["identified"]).isdisjoint(report["fixed"])
    assert all(f["reason"] for f in report["fixed"].values())


def test_hold_orientations_are_read_from_the_held_joints():
    """Holds whose joints, as held (second half), agree within the tolerance share a label,
    whatever move into the pose came first; free space gets None; another mass in the same
    orientation gets the same label."""
    from psmforce.estimators.training.ati_free import ORIENTATION_TOLERANCE_RAD, hold_orientations
    rng = np.random.default_rng(0)

    def hold(pose, condition=KNOWN_LOAD_CONDITION, approach=0.0):
        q = np.tile(np.r_[0.3, 0.2, 0.15, pose, 0.0], (100, 1)) + 1e-3 * rng.standard_normal(
            (100, 7))
        q[:40, 3:6] += approach  # the wrist moving into the pose
        return Trial(path="x.csv", condition=condition, split="train",
                     frame=pd.DataFrame(q, columns=list(JOINT_POSITIONS)))
    a, b = (0.0, 0.7, 0.0), (0.0, -0.7, 0.0)
    near = (0.0, 0.7 + 0.5 * ORIENTATION_TOLERANCE_RAD, 0.0)
    far = (0.0, 0.7 + 2 * ORIENTATION_TOLERANCE_RAD, 0.0)
    trials = [hold(a, "Free"), hold(a), hold(b, approach=0.3), hold(near, approach=-0.3),
              hold(b), hold(far)]
    assert hold_orientations(trials) == [None, 0, 1, 0, 1, 2]


def test_sign_pairs_group_each_orientation_with_its_opposite():
    """Unit "sign_pair": an orientation and its opposite (the same arm pose and roll, the
    wrist's pitch and yaw negated) share a label, whatever mass hangs in either; a straight
    wrist, an orientation whose opposite is not held, and one that differs in roll stay alone;
    free space gets None."""
    from psmforce.estimators.training.ati_free import (JACKKNIFE_UNITS, CalibrationError,
                                                       hold_orientations)
    from psmforce.identification.prior_identifiability import JACKKNIFE_OVER
    rng = np.random.default_rng(1)

    def hold(roll, pitch, yaw, condition=KNOWN_LOAD_CONDITION):
        q = np.tile(np.r_[0.3, 0.2, 0.15, roll, pitch, yaw, 0.0], (60, 1)) + 1e-3 * (
            rng.standard_normal((60, 7)))
        return Trial(path="x.csv", condition=condition, split="train",
                     frame=pd.DataFrame(q, columns=list(JOINT_POSITIONS)))
    trials = [hold(0, 0.7, 0, "Free"), hold(0, 0.7, 0.7), hold(1.57, 0.7, 0),
              hold(0, -0.7, -0.7), hold(0, 0, 0), hold(-1.57, -0.7, 0), hold(0, 0.7, 0.7),
              hold(1.57, -0.7, 0), hold(0, 0, 0.7)]
    assert hold_orientations(trials) == [None, 0, 1, 2, 3, 4, 0, 5, 6]
    assert hold_orientations(trials, "sign_pair") == [None, 0, 1, 0, 2, 3, 0, 1, 4]
    assert set(JACKKNIFE_UNITS) == set(JACKKNIFE_OVER) - {"trials"}
    with pytest.raises(CalibrationError, match="unit must be one of"):
        hold_orientations(trials, "pair")


def test_the_hold_rule_is_asked_for_with_the_identification_only(tmp_path, capsys):
    """``calibrate --hold-rule unresolved`` chooses what the instrument's identification holds:
    without known loads or ``--prior-refit identified`` it is refused by name (CLI and
    library), an unknown rule too; the CLI's
    choices are the identification's (:data:`~psmforce.identification.prior_selection.
    HOLD_RULES`)."""
    from psmforce.cli import options
    from psmforce.cli.main import main
    from psmforce.estimators.training.calibrate import CalibrationError, calibrate
    from psmforce.identification.prior_selection import HOLD_RULES
    assert options.HOLD_RULES == HOLD_RULES
    paths = (tmp_path / "m.pt", tmp_path, tmp_path / "o.pt")
    assert main(["calibrate", str(paths[0]), "--data", str(tmp_path), "--out", str(paths[2]),
                 "--free-space", "--hold-rule", "unresolved"]) == 2
    assert "--hold-rule: only with --known-loads" in capsys.readouterr().err
    with pytest.raises(CalibrationError, match="hold_rule must be one of"):
        calibrate(*paths, free_space=True, hold_rule="loose")
    with pytest.raises(CalibrationError, match="hold_rule: only with known_loads"):
        calibrate(*paths, free_space=True, hold_rule="unresolved")


@pytest.mark.parametrize("option, choices, asked, unknown", [
    ("held_values", "HELD_VALUES", "checked", "loose"),
    ("jackknife_unit", "JACKKNIFE_UNITS", "sign_pair", "pairs"),
    ("clenched_lateral", None, True, "yes"),
    ("free_lateral_offsets", None, True, "yes")])
def test_the_identifications_options_are_asked_for_with_the_identification_only(
        tmp_path, capsys, option, choices, asked, unknown):
    """``calibrate --held-values checked``, ``--jackknife-unit sign_pair``,
    ``--clenched-lateral`` and ``--free-lateral-offsets`` set the instrument's identification
    through the load path, which runs with known loads or ``--prior-refit identified``; without
    either each is refused by name, by the CLI and by the library, and the library refuses a
    value it does not know. The CLI's choices are the library's."""
    from psmforce.cli import options
    from psmforce.cli.main import main
    from psmforce.estimators.training import calibrate as calibration
    if choices is not None:
        assert getattr(options, choices) == getattr(calibration, choices)
    flag = "--" + option.replace("_", "-")
    argv = ["calibrate", str(tmp_path / "m.pt"), "--data", str(tmp_path), "--out",
            str(tmp_path / "o.pt"), "--free-space", flag] + ([] if asked is True else [asked])
    assert main(argv) == 2
    assert (f"{flag}: only with --known-loads or --prior-refit identified"
            in capsys.readouterr().err)
    paths = (tmp_path / "m.pt", tmp_path, tmp_path / "o.pt")
    with pytest.raises(calibration.CalibrationError,
                       match=f"{option} must be (one of|True or False)"):
        calibration.calibrate(*paths, free_space=True, **{option: unknown})
    with pytest.raises(calibration.CalibrationError, match=f"{option}: only with known_loads "
                                                         f"or prior_refit='identified'"):
        calibration.calibrate(*paths, free_space=True, **{option: asked})


def test_prior_refit_is_asked_for_without_an_ati_only(tmp_path, capsys):
    """``calibrate --prior-refit identified`` runs the identification on the free-space
    recordings (with or without known loads); with the ATI it is refused by name (CLI and
    library), and an unknown refit too. The CLI's choices are the library's less "per_mount",
    which ``psmforce remount`` runs."""
    from psmforce.cli import options
    from psmforce.cli.main import main
    from psmforce.estimators.training import calibrate as calibration
    assert options.PRIOR_REFITS == tuple(c for c in calibration.PRIOR_REFITS
                                         if c != "per_mount")
    argv = ["calibrate", str(tmp_path / "m.pt"), "--data", str(tmp_path), "--out",
            str(tmp_path / "o.pt"), "--prior-refit", "identified"]
    assert main(argv) == 2
    assert "--prior-refit identified: only with --free-space" in capsys.readouterr().err
    paths = (tmp_path / "m.pt", tmp_path, tmp_path / "o.pt")
    for kw in ({"prior_refit": "curve", "free_space": True}, {"prior_refit": "identified"}):
        with pytest.raises(calibration.CalibrationError, match="prior_refit must be one of"):
            calibration.calibrate(*paths, **kw)


def test_network_off_is_refused_where_it_cannot_hold(tmp_path, capsys):
    """``calibrate --network-off``: 'carried' needs the identified prior (CLI and library); axis
    names must be distinct axes (CLI and library); the CLI's rules are the library's."""
    from psmforce.cli import options
    from psmforce.cli.main import main
    from psmforce.estimators.training import calibrate as calibration
    assert options.NETWORK_OFF_RULES == calibration.NETWORK_OFF_RULES
    assert options.NETWORK_PRIORS == calibration.NETWORK_PRIORS
    argv = ["calibrate", str(tmp_path / "m.pt"), "--data", str(tmp_path), "--out",
            str(tmp_path / "o.pt"), "--free-space", "--network-off"]
    assert main(argv + ["carried"]) == 2
    assert "--network-off carried: only with --prior-refit identified" in (
        capsys.readouterr().err)
    assert main(argv + ["Fx", "Fw"]) == 2
    assert "--network-off: one of none, carried or distinct axis names" in (
        capsys.readouterr().err)
    paths = (tmp_path / "m.pt", tmp_path, tmp_path / "o.pt")
    with pytest.raises(calibration.CalibrationError, match="'carried' only with prior_refit"):
        calibration.calibrate(*paths, free_space=True, network_off="carried")
    with pytest.raises(calibration.CalibrationError, match="distinct axis names"):
        calibration.calibrate(*paths, free_space=True, network_off=("Fy", "Fy"))
    assert calibration.network_off_axes(("Fz", "Fx"), {}) == ("Fx", "Fz")
    assert calibration.network_off_axes("carried", {"crosstalk_fx": 0.01}) == ("Fx",)
    assert calibration.network_off_axes("none", {"crosstalk_fx": 0.01}) == ()


@pytest.mark.slow
def test_the_clenches_lateral_forces_pin_down_the_sensors_lateral_cross_talk(tmp_path):
    """Free space and the jaws clenched on each other, no weight, as the excitation composes
    them (two Fourier motions, four clenches at the largest grip, two light ones): read through
    the load path with the clenched samples' lateral forces counted, the sensor's cross-talk of
    the axial force into fy comes back within 2 % of the drawn tool's (the grips move the axial
    reading and put no lateral force through the section); left out, the same fit misses it by
    more than 10 %. The identification passes the option to every fit and frees the term."""
    from psmforce.estimators.training.ati_free import free_space_trials
    from psmforce.estimators.training.calibrate import identify_instrument, instrument_frames
    from psmforce.experiments.prior_recovery import default_bench_truth
    from psmforce.identification.prior import NAMES, InternalForcePrior
    from psmforce.sim.ati_free import FREE_SPACE, simulate_ati_free
    from psmforce.sim.excitation import assemble, candidates, excitation_limits
    limits = excitation_limits()
    pool = candidates(0, 10.0, limits, InstrumentParams())
    clench = [p for p in pool if p[0] == "clench"]
    parts = ([p for p in pool if p[0] == "fourier"][:2]
             + [p for p in clench if p[2]["grip_nm"] == max(c[2]["grip_nm"] for c in clench)][:4]
             + [p for p in clench if p[2]["grip_nm"] <= 0.005][:2])
    simulate_ati_free(tmp_path / "g", seed=5, scale=0.01, free_minutes=0.3,
                      excitation_q=assemble(parts, limits, 0).q, tool_seed=1215)
    trials = free_space_trials(load_dataset(tmp_path / "g" / FREE_SPACE,
                                            require_targets=False), 10.0)
    truth = default_bench_truth(InstrumentParams().sample(1215, 1.0))["crosstalk_fy"]
    k = NAMES.index("crosstalk_fy")
    fitted = {lateral: InternalForcePrior.fit(
        instrument_frames(trials), inputs="load_path", crosstalk="full", report=False,
        clenched_lateral=lateral).params[k] for lateral in (True, False)}
    assert abs(fitted[True] / truth - 1) < 0.02, (fitted, truth)
    assert abs(fitted[False] / truth - 1) > 0.1, (fitted, truth)
    prior = identify_instrument(trials, hold_rule="unresolved", clenched_lateral=True)
    sel = prior.info["selection"]
    assert sel["clenched_lateral"] is True and prior.info["clenched_lateral"] is True
    assert "crosstalk_fy" in [*sel["identified"], *sel["estimated"]]
