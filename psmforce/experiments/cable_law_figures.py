"""Hysteresis, friction and compliance figures of one cable transmission (input spindle -> jaw),
computed the same way on a real EndoWrist and on the simulated bench's cable law.

The real side is the MRD Lab bench (:mod:`psmforce.identification.transmission.recording`, O'Neill
et al., RA-L 2018): a motor turns one input spindle of a da Vinci Si Maryland forceps through +-30
deg sinusoids (0.1-0.5 Hz), a second motor loads the jaw with a constant resistive torque (10-100
%), torque sensors and encoders on both ends. The simulated side drives one blade cable pair of the
bench's Cadiere forceps through :func:`psmforce.sim.cables.transmission` (the bench's own cable law,
whatever ``InstrumentParams`` / ``Effects`` it is given) with the same input strokes and frequencies
against the same style of load (:func:`simulate_run`).

Common frame (:class:`TransmissionRun`; both sides are mapped into it before any figure):

* ``input_angle_rad``: the input spindle / instrument disc, positive towards closing (driving the
  jaw against the load); ``input_torque_nm``: the torque the drive applies to it, positive
  towards closing.
* ``output_angle_rad``: the jaw / blade, positive towards closing; ``output_torque_nm``: the
  torque the transmission delivers on the load, positive towards closing (so a resistive load
  reads positive: the real jaw sensor's sign flipped).

Figures of one session (a grid of runs over drive frequency x load level; :func:`session_figures`),
all read at mid-stroke (input angle within +-15 % of the stroke around its middle, moving faster
than a quarter of the run's 95th-percentile speed, closing and opening passes separately):

``kinematic_ratio``
    ``n`` = output angle per input angle: the common slope of a least-squares line through the
    closing and opening passes (one intercept per direction), median over the runs.
``friction_load_slope`` (checked)
    The transmission's friction torque referred to the output,
    ``F = ((tau_in,close - tau_in,open) / n - (tau_out,close - tau_out,open)) / 2`` (half the
    input-torque difference between closing and opening at the same position, less whatever the
    load itself changed between the passes), against the load ``L = (tau_out,close +
    tau_out,open) / 2``: the slope ``dF/dL`` of a least-squares line over all runs. Dimensionless
    and independent of the instrument's size: for a pure capstan ``tau_in = n^-1 L exp(+-mu)``
    it is ``sinh(mu)``.
``friction_frequency_ratio`` (checked)
    ``F`` at the highest drive frequency over ``F`` at the lowest, per load level, averaged over
    the load levels (1 for a rate-independent transmission; NaN without friction or without two
    frequencies).
``loop_width_fraction`` (checked)
    Width of the output-angle vs input-angle loop at mid-stroke, ``theta_out,open -
    theta_out,close`` at the same input angle (the difference of the two intercepts above: the
    motion lost at each reversal, positive when the jaw lags), over the output stroke ``n x``
    the input stroke (1st to 99th percentile); median over the runs. Dimensionless.
``compliance_fraction`` (checked)
    The transmission's static compliance ``c = d(wind-up)/dL`` (rad/Nm at the output), the
    least-squares slope over all runs of the mid-stroke wind-up ``u = n theta_in - theta_out`` (mean
    of the closing and opening passes) against the load ``L``, made dimensionless as ``c x L_full /
    stroke_out``: the fraction of the stroke the jaw yields under the session's full load ``L_full``
    (its largest ``L``). Needs the encoders of all runs on one zero
    (:func:`psmforce.identification.transmission.recording.home_session`; the simulator starts every
    run at 0).

``zero_load_friction_fraction`` (checked)
    Friction at zero load: the intercept of the ``F`` line (``zero_load_friction_nm``, Nm at the
    output) over ``L_full``, dimensionless like the slope (the friction the transmission needs to
    move unloaded: pretension, bearing and seal friction).

Also reported: ``kinematic_ratio`` with its ratio (the two instruments' geometry, no rule) and
``friction_fraction_at_full_load`` (``F(L_full) / L_full``). Over several folders
:func:`across_folders` states the real folders' own spread per figure and the rule that applies
(docs/simulator.md section 12b).

Stopping positions (the roll and pitch folders, ``ZXY.TXT``): the friction line is shared, the
wind-up has one zero per stopping position, the frequency ratio pairs runs of one stopping
position and load level; the simulated side replays the folder's roll and wrist pitch
(:func:`session_pose`) and each stopping position as the blade's centre.

Instrument size. Angles and torque ratios are dimensionless already; what differs between two instruments
is where their loads sit relative to their cables. The cable law lives in cable tensions (N) and
cable travel (m): a jaw torque ``tau`` asks a differential tension ``tau / r`` of the jaw pulley
radius ``r``, an angle ``theta`` moves ``theta r`` of cable. :func:`simulated_session` therefore
gives the simulated blade the real runs' cable travel and cable tensions: the same input-disc
stroke (the real tool's input spindle turns by the same angle as the simulated disc; both are
da Vinci Si instruments on the same four-disc interface, so their input drums are taken to have
the same radius ``R = BLADE_PER_DISC x r_blade``), and the real loads scaled by
``r_blade / r_jaw`` with the real jaw pulley radius estimated from its measured kinematic ratio,
``r_jaw = R / n_real``. The figures' ratios sim / real are then free of the two tools' sizes,
as far as that assumption holds: the loop-width and compliance ratios scale with the load scale
(``load_scale_factor``), the friction ratios do not.

Size: one comparison, both of its sides and the rule over folders in one place, so that the real
and the simulated runs provably go through the same figure functions; the per-run geometry
(:func:`mid_stroke`), the session figures, the MRD Lab side and the bench side are each a short
section.
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from psmforce.identification.transmission.recording import home_session, read_transmission_session
from psmforce.sim import cables
from psmforce.sim.params import Effects, InstrumentParams
from psmforce.sim.sensors import COUPLING

BLADE_PER_DISC = float(COUPLING[3, 3])
"""Blade angle per instrument-disc angle of the Cadiere's blade discs (dVRK coupling, 1.2177):
``blade_1 = BLADE_PER_DISC x disc_3`` at zero wrist pitch; the disc's drum radius is
``BLADE_PER_DISC x pulley_radius_blade_m``."""
MID_STROKE_BAND = 0.15
"""Half-width of the mid-stroke band, as a fraction of the input stroke."""
MOVING_SPEED_FRACTION = 0.25
"""A sample is "moving" when its input speed exceeds this fraction of the run's 95th-percentile
speed."""
SPEED_WINDOW_S = 0.05
"""Half-width of the central difference that estimates the input speed (s)."""
CHECKED = ("loop_width_fraction", "friction_load_slope", "friction_frequency_ratio",
           "compliance_fraction", "zero_load_friction_fraction")
"""The figures the calibration rule applies to (sim / real within :data:`RATIO_RANGE`, or within
the real folders' own spread where that is wider: :func:`across_folders`)."""
FIGURES = ("kinematic_ratio",) + CHECKED
"""The figures compared (:func:`compare`): the kinematic ratio is reported with its ratio but is
the two instruments' geometry (the Cadiere's blade-disc coupling against the Maryland's), not a
property of the cable law, so no rule applies to it."""
RATIO_RANGE = (0.67, 1.5)
MRDLAB_FREQUENCY_HZ = (0.1, 0.2, 0.3, 0.4, 0.5)
"""Drive frequency of the MRD Lab files by their first digit (X of ``XY.TXT``); checked against
each file's own spectrum by :func:`from_recording`."""
MRDLAB_AMPLITUDE_RAD = np.deg2rad(30.0)


class TransmissionFigureError(ValueError):
    """Runs from which a figure cannot be computed; the message names the run and the problem."""


@dataclass(frozen=True)
class TransmissionRun:
    """One recording in the common frame (module docstring); every array (N,) on ``time_s``."""

    name: str
    frequency_hz: float
    load_level: int
    """Index of the programmed load level (0 = lightest); runs with the same index are compared
    across frequencies."""
    time_s: np.ndarray
    input_angle_rad: np.ndarray
    input_torque_nm: np.ndarray
    output_angle_rad: np.ndarray
    output_torque_nm: np.ndarray
    stop_index: int = 0
    """Index of the jaw's stopping position (Z of ``ZXY.TXT``; 0 where a session has one): runs
    at different stopping positions are compared across frequencies and loads only at the same
    stopping position, and their wind-up has its own zero (:func:`session_figures`)."""
    stop_yaw_rad: float = 0.0
    """The stopping position's ``%Yaw_rad=`` header value (0 where absent): where the jaw's
    stroke is centred (:func:`simulated_session` replays it as the blade's centre)."""


# --------------------------------------------------------------------------- per run

def _check_run(run: TransmissionRun) -> None:
    arrays = (run.time_s, run.input_angle_rad, run.input_torque_nm, run.output_angle_rad,
              run.output_torque_nm)
    n = len(run.time_s)
    if any(np.ndim(a) != 1 or len(a) != n for a in arrays):
        raise TransmissionFigureError(f"{run.name}: the five arrays must be (N,) of one length")
    if n < 20 or not all(np.isfinite(a).all() for a in arrays):
        raise TransmissionFigureError(f"{run.name}: {n} samples or non-finite values")
    if not (np.diff(run.time_s) > 0).all():
        raise TransmissionFigureError(f"{run.name}: time_s must increase")


def input_speed(run: TransmissionRun) -> np.ndarray:
    """(N,) input angular speed (rad/s): central difference over +-``SPEED_WINDOW_S``."""
    t, a = run.time_s, run.input_angle_rad
    dt = float(np.median(np.diff(t)))
    k = max(1, int(round(SPEED_WINDOW_S / dt)))
    lo = np.clip(np.arange(len(t)) - k, 0, len(t) - 1)
    hi = np.clip(np.arange(len(t)) + k, 0, len(t) - 1)
    return (a[hi] - a[lo]) / (t[hi] - t[lo])


def mid_stroke(run: TransmissionRun) -> dict[str, float]:
    """The run's mid-stroke quantities: input stroke (rad, 1st-99th percentile), kinematic ratio
    ``n`` and loop width (rad at the output) from the two-intercept line, and the mean input and
    output torques (Nm) and angles (rad) of the closing and opening passes through the band."""
    _check_run(run)
    a_in, a_out = run.input_angle_rad, run.output_angle_rad
    lo, hi = np.percentile(a_in, [1.0, 99.0])
    stroke = float(hi - lo)
    if stroke <= 0:
        raise TransmissionFigureError(f"{run.name}: the input angle does not move")
    v = input_speed(run)
    fast = np.abs(v) > MOVING_SPEED_FRACTION * np.percentile(np.abs(v), 95.0)
    band = np.abs(a_in - 0.5 * (lo + hi)) < MID_STROKE_BAND * stroke
    close, open_ = band & fast & (v > 0), band & fast & (v < 0)
    if close.sum() < 5 or open_.sum() < 5:
        raise TransmissionFigureError(f"{run.name}: fewer than 5 closing or opening samples at "
                                      f"mid-stroke ({close.sum()}, {open_.sum()})")
    sel = close | open_
    design = np.stack([a_in[sel], close[sel].astype(float), open_[sel].astype(float)], axis=1)
    n, b_close, b_open = np.linalg.lstsq(design, a_out[sel], rcond=None)[0]
    if not n > 0:
        raise TransmissionFigureError(f"{run.name}: output angle does not follow the input "
                                      f"(slope {n:.3g}); check the sign conventions")
    out = {"stroke_in_rad": stroke, "kinematic_ratio": float(n),
           "loop_width_rad": float(b_open - b_close)}
    for tag, m in (("close", close), ("open", open_)):
        out[f"tau_in_{tag}_nm"] = float(run.input_torque_nm[m].mean())
        out[f"tau_out_{tag}_nm"] = float(run.output_torque_nm[m].mean())
        out[f"theta_in_{tag}_rad"] = float(a_in[m].mean())
        out[f"theta_out_{tag}_rad"] = float(a_out[m].mean())
    return out


def friction_and_load(m: dict[str, float], kinematic_ratio: float) -> tuple[float, float]:
    """(F, L) in Nm at the output from :func:`mid_stroke`'s means (module docstring)."""
    n = kinematic_ratio
    friction = 0.5 * ((m["tau_in_close_nm"] - m["tau_in_open_nm"]) / n
                      - (m["tau_out_close_nm"] - m["tau_out_open_nm"]))
    load = 0.5 * (m["tau_out_close_nm"] + m["tau_out_open_nm"])
    return float(friction), float(load)


def wind_up(m: dict[str, float], kinematic_ratio: float) -> float:
    """Mid-stroke wind-up ``n theta_in - theta_out`` (rad at the output), mean of both passes."""
    n = kinematic_ratio
    return float(0.5 * sum(n * m[f"theta_in_{tag}_rad"] - m[f"theta_out_{tag}_rad"]
                           for tag in ("close", "open")))


# --------------------------------------------------------------------------- per session

def session_figures(runs: list[TransmissionRun]) -> dict:
    """The figures of the module docstring for a grid of runs (at least two load levels; the
    frequency ratio needs two frequencies at one stopping position and load level, else it is
    NaN), plus a per-run table. Runs at several stopping positions (the roll and pitch folders)
    share one friction line, and one compliance slope with one wind-up zero per stopping
    position (the kinematic ratio's error times each position's offset would otherwise enter
    the wind-up); with one stopping position both are the plain least-squares lines."""
    if len(runs) < 2:
        raise TransmissionFigureError(f"need at least 2 runs, got {len(runs)}")
    per = [mid_stroke(r) for r in runs]
    n = float(np.median([m["kinematic_ratio"] for m in per]))
    table = []
    for r, m in zip(runs, per):
        f, load = friction_and_load(m, n)
        table.append({"name": r.name, "frequency_hz": r.frequency_hz, "load_level": r.load_level,
                      "stop_index": r.stop_index, "stop_yaw_rad": r.stop_yaw_rad,
                      "load_nm": load, "friction_nm": f, "wind_up_rad": wind_up(m, n),
                      "loop_width_rad": m["loop_width_rad"], "stroke_in_rad": m["stroke_in_rad"],
                      "kinematic_ratio": m["kinematic_ratio"]})
    loads = np.array([t["load_nm"] for t in table])
    if np.ptp(loads) <= 0.2 * np.abs(loads).max():
        raise TransmissionFigureError("the runs' loads span less than 20 % of the largest: no "
                                      "slope against load")
    friction = np.array([t["friction_nm"] for t in table])
    slope, intercept = np.polyfit(loads, friction, 1)
    stops = sorted({t["stop_index"] for t in table})
    if len(stops) == 1:
        compliance = np.polyfit(loads, [t["wind_up_rad"] for t in table], 1)[0]
    else:
        design = np.column_stack([loads] + [[float(t["stop_index"] == z) for t in table]
                                            for z in stops])
        compliance = np.linalg.lstsq(design, [t["wind_up_rad"] for t in table], rcond=None)[0][0]
    stroke_out = n * float(np.median([t["stroke_in_rad"] for t in table]))
    full = float(loads.max())

    freqs = sorted({r.frequency_hz for r in runs})
    ratios = []
    for key in sorted({(r.stop_index, r.load_level) for r in runs}):
        at = {t["frequency_hz"]: t["friction_nm"] for t in table
              if (t["stop_index"], t["load_level"]) == key}
        if freqs[0] in at and freqs[-1] in at and len(freqs) > 1 and at[freqs[0]] != 0:
            ratios.append(at[freqs[-1]] / at[freqs[0]])
    return {
        "kinematic_ratio": n,
        "stroke_out_rad": stroke_out,
        "full_load_nm": full,
        "loop_width_fraction": float(np.median([t["loop_width_rad"] for t in table]) / stroke_out),
        "friction_load_slope": float(slope),
        "friction_frequency_ratio": float(np.mean(ratios)) if ratios else float("nan"),
        "frequencies_hz": [float(freqs[0]), float(freqs[-1])],
        "compliance_rad_per_nm": float(compliance),
        "compliance_fraction": float(compliance * full / stroke_out),
        "zero_load_friction_nm": float(intercept),
        "zero_load_friction_fraction": float(intercept / full),
        "friction_fraction_at_full_load": float((intercept + slope * full) / full),
        "stopping_positions": len(stops),
        "runs": table,
    }


def compare(real: dict, sim: dict, figures=FIGURES) -> dict:
    """Per figure: real, sim, ratio sim / real and whether it lies in :data:`RATIO_RANGE`;
    ``measurable`` False (ratio and ok None) where either side is NaN or None or the real one is
    0 (the frequency ratio of a session driven at one frequency)."""
    rows = {}
    for k in figures:
        # None: a figure a JSON holds as null (no frequency ratio for one drive frequency)
        measurable = bool(real[k] is not None and sim[k] is not None and np.isfinite(real[k])
                          and np.isfinite(sim[k]) and real[k] != 0)
        ratio = float(sim[k] / real[k]) if measurable else None
        rows[k] = {"real": _finite(real[k]), "sim": _finite(sim[k]), "ratio": ratio,
                   "ok": bool(RATIO_RANGE[0] <= ratio <= RATIO_RANGE[1]) if measurable else None,
                   "measurable": measurable}
    return rows


def _finite(v: float | None) -> float | None:
    return float(v) if v is not None and np.isfinite(v) else None


def across_folders(results: dict[str, dict], figures=CHECKED) -> dict:
    """The rule over every folder (``results``: folder name -> :func:`real_vs_sim`), per figure:
    the real folders' own spread (min..max of the measurable ones), and the rule that applies.

    ``"band"``: every measurable ratio sim / real within :data:`RATIO_RANGE`. Where the real
    folders spread wider than one value could sit in that band of each (max / min above
    ``RATIO_RANGE[1] / RATIO_RANGE[0]``), ``"real spread"``: every folder's ratio within the band
    *or* its sim value within the real min..max. ``met`` per figure and overall."""
    out = {}
    for k in figures:
        rows = {name: r["comparison"][k] for name, r in results.items()}
        real = [row["real"] for row in rows.values() if row["measurable"]]
        if not real:
            out[k] = {"rule": "not measurable", "met": None, "folders": {}}
            continue
        lo, hi = float(min(real)), float(max(real))
        wide = lo > 0 and hi / lo > RATIO_RANGE[1] / RATIO_RANGE[0]
        folders = {}
        for name, row in rows.items():
            if not row["measurable"]:
                folders[name] = {"ratio": None, "ok": None}
                continue
            in_spread = bool(lo <= row["sim"] <= hi)
            folders[name] = {"ratio": row["ratio"], "in_band": row["ok"],
                             "sim_in_real_spread": in_spread,
                             "ok": bool(row["ok"] or (wide and in_spread))}
        out[k] = {"real_min": lo, "real_max": hi, "real_spread": hi / lo if lo > 0 else None,
                  "rule": "real spread" if wide else "band",
                  "met": all(f["ok"] for f in folders.values() if f["ok"] is not None),
                  "folders": folders}
    return out


# --------------------------------------------------------------------------- the real bench

def from_recording(rec) -> TransmissionRun:
    """A :class:`psmforce.identification.transmission.recording.TransmissionRecording` in the common frame.

    Input = the spindle encoder and torque sensor (the spindle encoder counts against the motor:
    its sign is flipped, and checked against the motor encoder); output = the jaw encoder and
    the jaw torque sensor with its sign flipped (the loader's torque resists closing, so the
    transmission delivers ``-jaw_torque_nm``). The drive frequency is the file's ``%Freq_Hz=``
    header line where it has one (the roll and pitch folders, whose X index means 0.3 / 0.5 Hz),
    else its X index (:data:`MRDLAB_FREQUENCY_HZ`); either is checked against the motor angle's
    spectrum. The stopping position: Z of ``ZXY.TXT`` and the ``%Yaw_rad=`` header value."""
    motor = rec.motor_angle_rad - rec.motor_angle_rad.mean()
    if np.corrcoef(rec.spindle_angle_rad, motor)[0, 1] > -0.9:
        raise TransmissionFigureError(f"{rec.name}: the spindle encoder does not run against the "
                                      "motor encoder as expected")
    if np.corrcoef(rec.jaw_angle_rad, motor)[0, 1] < 0.9:
        raise TransmissionFigureError(f"{rec.name}: the jaw encoder does not follow the motor")
    header = getattr(rec, "header", None) or {}
    if "Freq_Hz" in header:
        f, said = float(header["Freq_Hz"]), "its header says"
    elif 0 <= rec.frequency_index < len(MRDLAB_FREQUENCY_HZ):
        f, said = MRDLAB_FREQUENCY_HZ[rec.frequency_index], "its name says"
    else:
        raise TransmissionFigureError(f"{rec.name}: unknown frequency index {rec.frequency_index}")
    spectrum = np.abs(np.fft.rfft(motor))
    f_peak = np.fft.rfftfreq(len(motor), 1.0 / rec.rate_hz)[1 + np.argmax(spectrum[1:])]
    if abs(f_peak - f) > 0.02:
        raise TransmissionFigureError(f"{rec.name}: drives at {f_peak:.3f} Hz, {said} {f} Hz")
    stop = getattr(rec, "stop_index", None)
    return TransmissionRun(name=rec.name, frequency_hz=f, load_level=rec.load_index,
                           time_s=rec.time_s, input_angle_rad=-rec.spindle_angle_rad,
                           input_torque_nm=rec.spindle_torque_nm,
                           output_angle_rad=rec.jaw_angle_rad,
                           output_torque_nm=-rec.jaw_torque_nm,
                           stop_index=0 if stop is None else int(stop),
                           stop_yaw_rad=float(header.get("Yaw_rad", 0.0)))


def real_session(folder: str | Path, rate_hz: float = 100.0) -> list[TransmissionRun]:
    """Every file of an MRD Lab session folder that passes its data checks (the reader leaves
    the others out with a warning), homed once (one encoder zero for the session), in the
    common frame."""
    return [from_recording(r) for r in home_session(read_transmission_session(folder, rate_hz))]


_ROLL = re.compile(r"roll of ([+-]?\d+(?:\.\d+)?) degrees", re.IGNORECASE)
_PITCH = re.compile(r"pitch of ([+-]?\d+(?:\.\d+)?) degrees", re.IGNORECASE)


def session_pose(folder: str | Path) -> dict[str, float]:
    """The shaft roll and wrist pitch (rad) a session was recorded at, from its ``ReadME.txt``
    ("This is a roll of -90 degrees", "a pitch of +60 degrees"); 0 where the folder has no such
    line (the XY folders: the 2018 paper's straight wrist, **assumed**). The angles are the
    dataset's (roll from its protractor's -90 deg mark); the bench's cable law depends on
    ``roll^2``, ``|roll|`` and ``|pitch|`` only, so their signs do not matter to it."""
    readme = next((p for p in Path(folder).iterdir() if p.name.lower() == "readme.txt"), None)
    text = readme.read_text(errors="replace") if readme is not None else ""
    pose = {}
    for key, pattern in (("roll_rad", _ROLL), ("pitch_rad", _PITCH)):
        m = pattern.search(text)
        pose[key] = float(np.deg2rad(float(m.group(1)))) if m else 0.0
    return pose


# --------------------------------------------------------------------------- the simulated bench

def simulate_run(frequency_hz: float, load_nm: float, params: InstrumentParams | None = None,
                 effects: Effects | None = None, amplitude_rad: float = MRDLAB_AMPLITUDE_RAD,
                 duration_s: float = 20.0, rate_hz: float = 100.0, load_level: int = 0,
                 name: str | None = None, roll_rad: float = 0.0, pitch_rad: float = 0.0,
                 blade_centre_rad: float = 0.0, stop_index: int = 0,
                 stop_yaw_rad: float = 0.0) -> TransmissionRun:
    """One run of the real experiment on the bench's cable law: the blade-1 disc (input) turns
    ``-amplitude cos(2 pi f t)`` about ``blade_centre_rad / BLADE_PER_DISC`` (rad of disc), the
    shaft roll and wrist pitch held at ``roll_rad``, ``pitch_rad``, blade 2 at 0; the blade
    carries a constant resistive load ``load_nm`` (Nm on the blade, opposing closing = positive
    blade_1 motion). Output: the blade's true angle (encoder - the cable law's deflection) and
    the load; input: the disc angle ``blade_1 / BLADE_PER_DISC`` (the blade disc's constant
    pick-up of a held pitch left out: the figures use slopes and differences only) and the disc
    torque the cables ask of the motor (``BLADE_PER_DISC x`` the blade-coordinate effort, which
    the pitch does not change). Only :func:`cables.transmission` is involved: no drive
    friction, noise or quantisation."""
    if not (frequency_hz > 0 and amplitude_rad > 0 and duration_s > 0 and rate_hz > 0):
        raise ValueError("frequency_hz, amplitude_rad, duration_s and rate_hz must be > 0")
    params = params or InstrumentParams()
    effects = effects or Effects()
    t = np.arange(int(round(duration_s * rate_hz))) / rate_hz
    disc = -amplitude_rad * np.cos(2.0 * np.pi * frequency_hz * t)
    blade = BLADE_PER_DISC * disc
    if blade_centre_rad:
        blade = blade + blade_centre_rad
        disc = blade / BLADE_PER_DISC
    q = np.zeros((len(t), 7))
    q[:, 3], q[:, 4] = roll_rad, pitch_rad
    # blade_1 = wrist_yaw - jaw / 2, blade_2 = wrist_yaw + jaw / 2: only blade_1 moves.
    q[:, 5], q[:, 6] = 0.5 * blade, -blade
    tau_load = np.zeros((len(t), 3))
    tau_load[:, 1] = -load_nm
    out = cables.transmission(q, tau_load, params, effects)
    effort, deflection = out["effort"], out["deflection"]   # (wrist_pitch, wrist_yaw, jaw)
    tau_blade = 0.5 * effort[:, 1] - effort[:, 2]            # inverse of distal_torque_to_joints
    blade_deflection = deflection[:, 1] - 0.5 * deflection[:, 2]
    return TransmissionRun(name=name or f"sim f={frequency_hz:g}Hz L={load_nm:.4g}Nm",
                           frequency_hz=float(frequency_hz), load_level=load_level, time_s=t,
                           input_angle_rad=disc, input_torque_nm=BLADE_PER_DISC * tau_blade,
                           output_angle_rad=blade - blade_deflection,
                           output_torque_nm=np.full(len(t), float(load_nm)),
                           stop_index=stop_index, stop_yaw_rad=stop_yaw_rad)


def load_scale(real_kinematic_ratio: float) -> float:
    """Simulated blade load per real jaw load at equal cable tension: ``r_blade / r_jaw`` with
    ``r_jaw = R / n_real`` and the same input-drum radius ``R = BLADE_PER_DISC r_blade`` (module
    docstring), i.e. ``n_real / BLADE_PER_DISC``."""
    if not real_kinematic_ratio > 0:
        raise ValueError(f"the real kinematic ratio must be > 0, got {real_kinematic_ratio}")
    return real_kinematic_ratio / BLADE_PER_DISC


def simulated_session(real: dict, params: InstrumentParams | None = None,
                      effects: Effects | None = None, rate_hz: float = 100.0,
                      duration_s: float = 20.0, load_scale_factor: float = 1.0,
                      pose: dict[str, float] | None = None) -> list[TransmissionRun]:
    """The real session's grid replayed on the cable law: per real run (``real`` is
    :func:`session_figures` of the real runs) one simulated run at its frequency, with the same
    input stroke (half the real run's input stroke as the disc amplitude), its measured load
    scaled to the blade by :func:`load_scale` (times ``load_scale_factor``: how far the
    equal-drum assumption may be off, for a sensitivity check), the session's roll and wrist
    pitch (``pose``, :func:`session_pose`; 0 when None) and its stopping position as the blade's
    centre, ``-Yaw_rad`` (the real jaw's homed mean angle falls by about 0.9 rad per rad of
    ``Yaw_rad``; the bench's cable law does not depend on the blade's centre, so this changes no
    figure: it is replayed for the record)."""
    scale = load_scale(real["kinematic_ratio"]) * load_scale_factor
    pose = pose or {}
    return [simulate_run(r["frequency_hz"], scale * r["load_nm"], params, effects,
                         amplitude_rad=0.5 * r["stroke_in_rad"], duration_s=duration_s,
                         rate_hz=rate_hz, load_level=r["load_level"], name=f"sim {r['name']}",
                         roll_rad=pose.get("roll_rad", 0.0), pitch_rad=pose.get("pitch_rad", 0.0),
                         blade_centre_rad=-r.get("stop_yaw_rad", 0.0),
                         stop_index=r.get("stop_index", 0),
                         stop_yaw_rad=r.get("stop_yaw_rad", 0.0))
            for r in real["runs"]]


def real_vs_sim(folder: str | Path, params: InstrumentParams | None = None,
                effects: Effects | None = None, load_scale_factor: float = 1.0,
                real: dict | None = None) -> dict:
    """Real figures of one MRD Lab session (``real``: already computed, to save reading it
    again), the simulated ones on its replayed grid at its pose, and the comparison of the
    :data:`FIGURES` (:func:`compare`)."""
    real = real or session_figures(real_session(folder))
    pose = session_pose(folder)
    sim = session_figures(simulated_session(real, params, effects,
                                            load_scale_factor=load_scale_factor, pose=pose))
    return {"session": Path(folder).name, "pose": pose, "real": real, "sim": sim,
            "load_scale_sim_per_real": load_scale(real["kinematic_ratio"]) * load_scale_factor,
            "comparison": compare(real, sim)}


def by_load_level(figures: dict) -> dict[str, list[float]]:
    """Per load level (ascending), the median over drive frequencies of the runs' load (Nm),
    friction (Nm), wind-up (rad) and loop width (rad), from :func:`session_figures`."""
    levels = sorted({t["load_level"] for t in figures["runs"]})
    out = {"load_level": levels}
    for k in ("load_nm", "friction_nm", "wind_up_rad", "loop_width_rad"):
        out[k] = [float(np.median([t[k] for t in figures["runs"] if t["load_level"] == lv]))
                  for lv in levels]
    return out


_SESSION = re.compile(r"^Tool_\d+_.+$")


def sessions(mrdlab_dir: str | Path) -> list[Path]:
    """The session folders of an MRD Lab data folder, in name order."""
    root = Path(mrdlab_dir)
    return sorted(p for p in root.iterdir() if p.is_dir() and _SESSION.match(p.name))
