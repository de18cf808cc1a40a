"""``psmforce excitation``: a free-space excitation for calibrating the instrument's
internal-force prior without a reference sensor, its report, and what known weights would add
(docs/ati_free.md).

Composes the two wings it sits above: the trajectory, its segments and the bench from
:mod:`psmforce.sim.excitation`, the prior's Fisher information and criteria from
:mod:`psmforce.identification.prior_design` (each HEX10 channel with the nominal HEX10's white
noise, :func:`channel_noise`). :func:`build` designs and scores; :func:`known_weights` weighs
masses hung at the tip; :func:`write` writes the setpoint CSV, the ROS 2 bag and the JSON report
into a locked, empty folder, all or nothing; :func:`excitation_cli` is the command.
"""

from __future__ import annotations

import shutil
from collections import Counter
from pathlib import Path

import numpy as np

from psmforce.core.files import folder_is_empty, locked_folder, write_json_atomic, write_text_atomic
from psmforce.identification import prior_design as pd_
from psmforce.io.bags.writing import write_setpoint_bag
from psmforce.robot.kinematics import default_psm
from psmforce.sim import excitation as ex
from psmforce.sim.bench import Contact
from psmforce.sim.params import InstrumentParams
from psmforce.sim.protocols import SAFE_COMPRESSION_N

FORMAT = "psmforce.excitation/1"
FILES = {"csv": "excitation.csv", "bag": "excitation_bag", "report": "excitation.json"}
"""What :func:`write` puts into the output folder."""
MIN_MINUTES, MAX_MINUTES = 0.2, 30.0
"""The excitation's duration: at least a settle and one clench, at most half an hour."""
MIN_WEIGHT_KG, MAX_WEIGHT_KG = 0.01, 0.2
"""A known weight's mass: heavy enough that the fit counts the sample's force only (0.05 N,
:func:`~psmforce.identification.prior.internal_wrench_target`), light enough for the wrist."""
WEIGHT_HOLD_S = 10.0
START_NS = 1_700_000_000_000_000_000
"""The bag's stamp of time 0 (fixed: the same arguments write the same files)."""
WEIGHT_ARM_POSE = np.array([0.3, 0.2, 0.15])
"""yaw, pitch (rad), insertion (m) at which the weights hang: the shaft tilted, so gravity has a
component across it in the HEX10 frame as well as along it."""
WEIGHT_WRIST_POSES = ((0.0, 0.0, 0.0), (0.0, 0.7, 0.0), (0.0, -0.7, 0.0), (0.0, 0.0, 0.7),
                      (0.0, 0.0, -0.7), (1.57, 0.7, 0.0), (-1.57, 0.0, 0.7), (0.0, 0.7, 0.7))
"""(roll, wrist_pitch, wrist_yaw) rad of the orientations a weight is hung in, jaw closed on
the string: a bent wrist turns the weight's pull into wrist-pitch and -yaw torques."""
WEIGHT_WRIST_POSES_PAIRED = tuple(
    pose for r, p, y in ((0.0, 0.7, 0.0), (0.0, 0.0, 0.7), (1.57, 0.7, 0.0), (-1.57, 0.0, 0.7),
                         (0.0, 0.7, 0.7), (0.0, 0.7, -0.7), (1.57, 0.0, 0.7), (-1.57, 0.7, 0.0))
    for pose in ((r, p, y), (r, 0.0 - p, 0.0 - y)))
"""Sixteen orientations in sign pairs (each bend and its opposite, one after the other): every
pair loads each cable pair's other side too, so the poses are redundant. With
:data:`WEIGHT_WRIST_POSES` (one negative pitch) the fit through the load path rests on single
poses, and a jackknife that leaves them out moves every parameter
(``studies/ati_free_identification.py``)."""


def check_out(out) -> None:
    """Refuse an output folder that is a symbolic link (never written through)."""
    if Path(out).is_symlink():
        raise ValueError(f"--out: {out} is a symbolic link; refusing to write through it (give "
                         f"a folder's own path)")


def channel_noise(params: InstrumentParams) -> np.ndarray:
    """(6,) the HEX10's white noise (N, Nm) that weighs each channel of the information."""
    return np.array([params.hex10_force_noise_n] * 3 + [params.hex10_moment_noise_nm] * 3)


def check_arguments(minutes: float, seed: int, weights_kg, paired_poses: bool = False) -> None:
    """ValueError in one line for arguments :func:`build` refuses, before any work."""
    if paired_poses and not weights_kg:
        raise ValueError("--paired-poses: only with --known-weights (it sets where they hang)")
    if not (isinstance(minutes, (int, float)) and MIN_MINUTES <= minutes <= MAX_MINUTES):
        raise ValueError(f"--minutes: must be in [{MIN_MINUTES:g}, {MAX_MINUTES:g}], got {minutes}")
    if isinstance(seed, bool) or not isinstance(seed, (int, np.integer)) or not 0 <= seed < 2 ** 32:
        raise ValueError(f"--seed: must be an integer in [0, {2 ** 32 - 1}], got {seed!r}")
    for m in weights_kg:
        if not (isinstance(m, (int, float)) and MIN_WEIGHT_KG <= m <= MAX_WEIGHT_KG):
            raise ValueError(f"--known-weights: each mass must be in [{MIN_WEIGHT_KG:g}, "
                             f"{MAX_WEIGHT_KG:g}] kg, got {m}")


def _fisher(params: InstrumentParams, reading: str = "efforts"):
    psm, noise = default_psm(), channel_noise(params)
    return lambda frame: pd_.fisher_information(frame, noise, psm=psm, reading=reading)


def _limit_use(q: np.ndarray, limits: ex.Limits) -> dict:
    """Per joint the largest finite-difference velocity and acceleration over their limits
    and whether the positions stay in the box."""
    vel = np.gradient(q, ex.DT, axis=0)
    acc = np.gradient(vel, ex.DT, axis=0)
    inside = (q >= limits.lower - 1e-9).all(axis=0) & (q <= limits.upper + 1e-9).all(axis=0)
    return {j: {"positions_inside": bool(i), "velocity_fraction": float(v), "acceleration_fraction": float(a)}
            for j, i, v, a in zip(ex.JOINTS, inside, np.abs(vel).max(axis=0) / limits.velocity,
                                  np.abs(acc).max(axis=0) / limits.acceleration)}


def build(minutes: float, seed: int, weights_kg=(), params: InstrumentParams | None = None,
          poses=WEIGHT_WRIST_POSES) -> tuple[ex.Excitation, dict]:
    """The excitation (:func:`psmforce.sim.excitation.design`) and its report: segments with the
    parameters each excites, the criteria of the excitation against a random motion of the same
    duration within the same limits and against the paper's free-space motion, the limits and
    their use, and with ``weights_kg`` what known weights add in each of ``poses``
    (:func:`known_weights`)."""
    check_arguments(minutes, seed, weights_kg)
    params = params or InstrumentParams()
    fisher = _fisher(params)
    exc = ex.design(seed, minutes, fisher, pd_.log_det, params)
    frame = ex.simulate_excitation(exc.q, params=params, effects=ex.QUIET)
    rows = [(int(round(s.start_s / ex.DT)), int(round((s.start_s + s.duration_s) / ex.DT)))
            for s in exc.segments]
    infos = [fisher(frame.iloc[a:b]) for a, b in rows]
    for seg, share in zip(exc.segments, pd_.segment_shares(infos, [s.duration_s for s in exc.segments])):
        seg.excites, seg.information_share = share["excites"], share["information_share"]
    duration = len(exc.q) * ex.DT
    motions = {"excitation": sum(infos),
               "random": fisher(ex.simulate_excitation(ex.random_motion(seed, duration, exc.limits),
                                                       params=params, effects=ex.QUIET)),
               "paper_free": sum(fisher(ex.simulate_excitation(q, params=params, effects=ex.QUIET))
                                 for q in ex.paper_free_motion(seed, duration))}
    summaries = {k: pd_.summary(v) for k, v in motions.items()}
    report = {
        "format": FORMAT, "seed": int(seed), "minutes_asked": float(minutes),
        "duration_s": duration, "samples": len(exc.q), "dt_s": ex.DT,
        "criterion": "greedy log-det per second of the prior's Fisher information (span-scaled) "
                     "at its design values, on the noise-free bench without drive friction "
                     "(sim.excitation.QUIET)",
        "channel_noise": dict(zip(("fx", "fy", "fz", "tx", "ty", "tz"), channel_noise(params).tolist())),
        "compared_with": {"random": "random waypoints of every joint in the same box, minimum-jerk "
                                    "moves within the same limits (sim.excitation.random_motion)",
                          "paper_free": "the protocols' continuous random free-space test trials "
                                        "(sim.excitation.paper_free_motion)"},
        "condition_number": {k: s["condition_number"] for k, s in summaries.items()},
        "log_det": {k: s["log_det"] for k, s in summaries.items()},
        "not_identifiable": {k: s["not_identifiable"] for k, s in summaries.items()},
        "standard_errors": {k: s["standard_errors"] for k, s in summaries.items()},
        "segment_counts": dict(Counter(s.kind for s in exc.segments)),
        "segments": [s.to_dict() for s in exc.segments],
        "limits": exc.limits.to_dict(), "limit_use": _limit_use(exc.q, exc.limits),
        "bench": {"min_hex10_fz_n": float(frame["fz"].min()),
                  "safe_compression_n": SAFE_COMPRESSION_N,
                  "max_grip_nm": max((s.spec.get("grip_nm", 0.0) for s in exc.segments), default=0.0)},
    }
    if weights_kg:
        report["known_weights"] = known_weights(
            weights_kg, {"excitation": motions["excitation"], "paper_free": motions["paper_free"]},
            params, poses, load_path_base=_fisher(params, "load_path")(frame))
    return exc, report


def weight_poses(poses=WEIGHT_WRIST_POSES) -> dict[str, np.ndarray]:
    """Orientation label -> the (7,) pose a weight hangs in, for each (roll, wrist_pitch,
    wrist_yaw) of ``poses`` (:data:`WEIGHT_WRIST_POSES` or :data:`WEIGHT_WRIST_POSES_PAIRED`)."""
    return {f"roll {r:+.2f} pitch {p:+.2f} yaw {y:+.2f}": np.r_[WEIGHT_ARM_POSE, r, p, y, 0.0]
            for r, p, y in poses}


def known_weights(weights_kg, bases: dict[str, np.ndarray], params: InstrumentParams | None = None,
                  poses=WEIGHT_WRIST_POSES, load_path_base: np.ndarray | None = None) -> dict:
    """Each mass (kg, the user's) hung at the jaw tip in each orientation of ``poses``
    (:func:`weight_poses`; :data:`WEIGHT_WRIST_POSES` or :data:`WEIGHT_WRIST_POSES_PAIRED`) for
    :data:`WEIGHT_HOLD_S` on the noise-free bench (the weight's pull along gravity, known from
    the kinematics, subtracted from the forces as the fit does); per base information (the
    excitation's, the paper's free motion's) what each adds and how many make every parameter
    identifiable (:func:`psmforce.identification.prior_design.known_weight_gains`), for the
    prior that reads the efforts (what ``calibrate`` refits for the estimator). With
    ``load_path_base`` (the excitation's information read through the load path), the same
    under ``load_path``: the identification of the instrument that ``calibrate --known-loads``
    runs (every parameter of the law; docs/ati_free.md 4.1). A hold that would overload the
    HEX10 is left out and named."""
    params = params or InstrumentParams()
    fisher, through_load = _fisher(params), _fisher(params, "load_path")
    cands, load_cands, unsafe = {}, {}, []
    for mass in weights_kg:
        for label, pose in weight_poses(poses).items():
            q = np.repeat(pose[None], int(round(WEIGHT_HOLD_S / ex.DT)), 0)
            frame = ex.simulate_excitation(q, params=params, effects=ex.QUIET,
                                           contact=Contact(kind="weight", mass_kg=float(mass)))
            name = f"{float(mass):g} kg, {label}"
            if frame["fz"].min() <= SAFE_COMPRESSION_N:
                unsafe.append(name)
                continue
            cands[name] = fisher(frame)
            if load_path_base is not None:
                load_cands[name] = through_load(frame)
    report = {"masses_kg": [float(m) for m in weights_kg], "hold_s": WEIGHT_HOLD_S,
              "arm_pose": WEIGHT_ARM_POSE.tolist(), "left_out_unsafe": unsafe,
              "orientations": list(weight_poses(poses)),
              **{base: pd_.known_weight_gains(info, cands) for base, info in bases.items()}}
    if load_path_base is not None:
        report["load_path"] = {"excitation": pd_.known_weight_gains(
            load_path_base, load_cands, reading="load_path")}
    return report


def write(out, exc: ex.Excitation, report: dict) -> dict[str, str]:
    """The setpoint CSV, the bag and the report (:data:`FILES`) into the folder ``out``, held
    locked (:func:`psmforce.core.files.locked_folder`) and empty before; each file written
    atomically, and on any failure every one already written removed. Returns the paths."""
    out = Path(out)
    check_out(out)
    paths = {k: out / v for k, v in FILES.items()}
    with locked_folder(out):
        if not folder_is_empty(out):
            raise ValueError(f"--out: {out} is not empty (refusing to overwrite or mix results; "
                             f"give a new folder)")
        report = {**report, "files": {k: v for k, v in FILES.items()}}
        try:
            write_text_atomic(paths["csv"], ex.setpoints_frame(exc.q, exc.dt).to_csv(
                index=False, float_format="%.9g"))
            report["files"]["topics"] = write_setpoint_bag(exc.q, exc.dt, paths["bag"],
                                                           start_ns=START_NS)
            write_json_atomic(paths["report"], report)
        except BaseException:
            paths["csv"].unlink(missing_ok=True)
            paths["report"].unlink(missing_ok=True)
            if paths["bag"].is_dir() and not paths["bag"].is_symlink():
                shutil.rmtree(paths["bag"], ignore_errors=True)
            raise
    return {k: str(p) for k, p in paths.items()}


def excitation_cli(out, minutes: float, seed: int, weights_kg=(), paired_poses: bool = False
                   ) -> dict:
    """``psmforce excitation``: :func:`build`, then :func:`write`; the report, with one line
    per figure printed. ``paired_poses``: the weights in :data:`WEIGHT_WRIST_POSES_PAIRED`
    (what identifying the instrument through the load path needs, docs/ati_free.md 4.1)."""
    exc, report = build(minutes, seed, tuple(weights_kg),
                        poses=WEIGHT_WRIST_POSES_PAIRED if paired_poses else WEIGHT_WRIST_POSES)
    write(out, exc, report)
    cn = report["condition_number"]
    print(f"wrote {out}: {report['duration_s']:.0f} s, segments "
          + ", ".join(f"{k} {n}" for k, n in report["segment_counts"].items()))
    print("condition number of the prior's information: "
          + ", ".join(f"{k} {v:.4g}" if v is not None else f"{k} inf" for k, v in cn.items()))
    if "known_weights" in report:
        weights = report["known_weights"]
        for label, gains in (("on top of paper_free", weights["paper_free"]),
                             ("on top of excitation", weights["excitation"]),
                             ("through the load path (calibrate's identification of the "
                              "instrument), on top of excitation",
                              weights["load_path"]["excitation"])):
            print(f"known weights {label}: {_needed_words(gains)}")
    return report


def _needed_words(gains: dict) -> str:
    """What :func:`~psmforce.identification.prior_design.known_weight_gains` found, in words:
    how many holds make every parameter identifiable, or which stay out of reach."""
    needed = gains["needed"]
    if needed == 0:
        return "none needed"
    if needed:
        return f"{needed} holds make every parameter identifiable"
    return (f"the holds given do not make every parameter identifiable; with all of them, "
            f"still not: {', '.join(gains['not_identifiable_with_all'])}")
