"""An excitation for calibrating the instrument without a reference sensor: a joint trajectory of
the PSM (7 joints with the jaw, at :data:`~psmforce.sim.motion.DT`) in free space, where the
HEX10 reads only the instrument's internal wrench, chosen so that it tells the most about the
internal-force prior's parameters (docs/ati_free.md).

It is made of segments (:class:`Segment`), each starting and ending at rest, joined by
minimum-jerk transitions: Fourier-series motions of every joint (:func:`fourier_segment`: wrist,
jaw and roll sweeps, arm orientations for gravity in the HEX10 frame) and self-loading clenches
(:func:`clench_segment`: the jaw commanded past closed at a grip effort and a wrist pose, so the
blade cables carry the grip and their pairs go slack, which free motion never does; the bench's
law is :func:`psmforce.sim.cables.jaw_grip_torque`). :func:`design` draws a pool of candidates
from a seed, runs each through the bench and keeps, greedily, the one that adds the most of a
criterion per second until the duration is spent. The criterion is the caller's (``score``
below): the prior's law lives in :mod:`psmforce.identification`, a wing this one does not import;
:mod:`psmforce.cli.excitation` passes the prior's Fisher information and its log-det.

Limits (:func:`excitation_limits`): positions of the arm inside the URDF's
(``psmforce/robot/urdf``) in a box around the paper's fixture pose (:data:`ARM_BOX`, a choice:
free space of the upright bench, away from the joint limits); roll within
:data:`~psmforce.sim.protocols.WRIST_LIMITS` (the paper's protocols); wrist pitch and yaw within
the URDF's limits less :data:`WRIST_MARGIN_RAD`; the jaw open up to ``WRIST_LIMITS``' 0.8 rad and
closed no further than the URDF's lower limit. Velocities: :data:`VELOCITY_FRACTION` of the URDF's
velocity limits. Accelerations: neither the reference facts nor the URDF give any;
:data:`ACCELERATION_LIMITS` is this module's choice. The wrist is not driven against a mechanical
stop: the reference facts give none inside the dVRK's software limits and the bench models none;
the clenches are the self-loading it holds.

Run on the bench (free space)::

    from psmforce.sim.excitation import read_setpoints, simulate_excitation
    q, dt = read_setpoints("out/excitation/excitation.csv")   # psmforce excitation --out ...
    frame = simulate_excitation(q, dt=dt, seed=0)             # the recording layout, sim_* truth
"""

from __future__ import annotations

import dataclasses
import io
from dataclasses import dataclass, field
from typing import Callable

import numpy as np
import pandas as pd

from psmforce.core.files import read_input_text
from psmforce.robot.conventions import JOINTS
from psmforce.robot.kinematics import default_psm
from psmforce.sim.bench import Contact, run_trajectory
from psmforce.sim.cables import JAW_CLOSED_RAD, jaw_command_for_grip, pair_pretension
from psmforce.sim.motion import DT, min_jerk
from psmforce.sim.params import Effects, InstrumentParams
from psmforce.sim.protocols import SAFE_COMPRESSION_N, WRIST_LIMITS, _random_free

UNITS = ("rad", "rad", "m", "rad", "rad", "rad", "rad")
SETPOINT_COLUMNS = ("time_s",) + tuple(f"{j}_{u}" for j, u in zip(JOINTS, UNITS))
"""The setpoint CSV's columns: time and each joint (dVRK order) with its unit."""
ARM_BOX = np.array([[-0.5, 0.5], [-0.4, 0.4], [0.12, 0.18]])
"""yaw, pitch (rad), insertion (m) the excitation keeps to: free space around the paper's
fixture pose (shaft down, tip about 0.17 m below the RCM), inside the URDF's limits."""
WRIST_MARGIN_RAD = 0.1
"""Wrist pitch and yaw stay this far inside the URDF's limits (the controller's tracking error)."""
JAW_OPEN_MAX_RAD = float(WRIST_LIMITS[3, 1])
VELOCITY_FRACTION = 0.5
"""Of the URDF's velocity limits: a gentle motion the dVRK tracks closely."""
ACCELERATION_LIMITS = np.array([1.5, 1.5, 0.2, 8.0, 8.0, 8.0, 8.0])
"""rad/s^2 (insertion m/s^2): this module's choice (no source gives the arm's)."""
FOURIER_S = 20.0
FOURIER_HARMONICS = 10
"""Harmonics of 1 / FOURIER_S: up to 0.5 Hz."""
RAMP_S = 1.5
"""A Fourier segment fades in and out over this long, so it starts and ends at rest."""
GRIP_LEVELS_NM = (0.002, 0.005, 0.01, 0.02)
"""Grip torques (Nm per blade) of the clench candidates: below and beyond the blade pairs'
slack point (2 T0 r_b = 3 mNm on the nominal tool). The jaw's effort limit is 0.16 Nm, but the
HEX10's overload comes first: each blade pair then carries about grip / r_b of compression, so
0.02 Nm is about 27 N a pair, and each candidate is also screened against
:data:`~psmforce.sim.protocols.SAFE_COMPRESSION_N` on the bench."""
CLENCH_POSES = 8
JAW_OPEN_RAD = 0.4
CLOSE_S, HOLD_S = 1.5, 3.0
SETTLE_S = 1.0
QUIET = dataclasses.replace(Effects(), sensor_noise=False, hex10_drift=False,
                            encoder_quantisation=False, coloured_effort_noise=False,
                            remount_offsets=False, current_quantisation=False,
                            drive_friction=False)
"""The bench a design is scored on: without noise (what a trajectory does, not what one
recording of it shows) and without the drives' and wrist discs' friction, which is proximal of
the HEX10 and tensions no cable: the prior would read it as cable torque, and a design scored
with it would count the discs' friction as excitation of the pulley radii."""
REGULARISATION = 1e-6
"""The greedy search starts from this fraction of the whole pool's information on each
parameter alone (a diagonal), so that its first log-det is finite; negligible against any
segment's."""


@dataclass(frozen=True)
class Limits:
    """Per joint (dVRK order) position box, velocity and acceleration limits (rad, m, s)."""

    lower: np.ndarray
    upper: np.ndarray
    velocity: np.ndarray
    acceleration: np.ndarray

    def to_dict(self) -> dict:
        source = ["ARM_BOX (inside the URDF)"] * 3 + [
            "protocols.WRIST_LIMITS (roll)", "URDF less WRIST_MARGIN_RAD",
            "URDF less WRIST_MARGIN_RAD", "URDF lower (closed) .. protocols.WRIST_LIMITS"]
        return {j: {"unit": u, "lower": float(lo), "upper": float(hi), "velocity": float(v),
                    "acceleration": float(a), "position_source": s,
                    "velocity_source": f"URDF x {VELOCITY_FRACTION}",
                    "acceleration_source": "excitation.ACCELERATION_LIMITS (a choice)"}
                for j, u, lo, hi, v, a, s in zip(JOINTS, UNITS, self.lower, self.upper,
                                                 self.velocity, self.acceleration, source)}


def excitation_limits() -> Limits:
    """The limits of the module docstring, from the bundled URDF."""
    psm = default_psm()
    lo, hi = psm.lower_limits.copy(), psm.upper_limits.copy()
    lo[:3], hi[:3] = np.maximum(lo[:3], ARM_BOX[:, 0]), np.minimum(hi[:3], ARM_BOX[:, 1])
    lo[3], hi[3] = WRIST_LIMITS[0]
    lo[4:6], hi[4:6] = lo[4:6] + WRIST_MARGIN_RAD, hi[4:6] - WRIST_MARGIN_RAD
    hi[6] = JAW_OPEN_MAX_RAD
    ids = [psm.model.joints[psm.model.getJointId(j)].idx_v for j in JOINTS]
    velocity = VELOCITY_FRACTION * np.asarray(psm.model.velocityLimit)[ids]
    return Limits(lo, hi, velocity, ACCELERATION_LIMITS.copy())


@dataclass
class Segment:
    """One part of the excitation: ``kind`` ("settle", "fourier", "clench", "transition"),
    where it starts and how long it lasts (s), what defines it (``spec``: grip torque and pose,
    centre and seed, ...), and, once scored on the bench, its share of each prior parameter's
    information and the parameters it excites (``excites``; computed, never typed:
    :func:`psmforce.identification.prior_design.segment_shares`)."""

    kind: str
    start_s: float
    duration_s: float
    spec: dict = field(default_factory=dict)
    excites: list[str] = field(default_factory=list)
    information_share: dict[str, float] = field(default_factory=dict)

    def to_dict(self) -> dict:
        return dataclasses.asdict(self)


@dataclass
class Excitation:
    """The joint setpoints ``q`` (N, 7) at ``dt``, their segments in time order, the limits."""

    q: np.ndarray
    segments: list[Segment]
    limits: Limits
    seed: int
    dt: float = DT


def _steps(duration_s: float, dt: float = DT) -> int:
    return max(2, int(round(duration_s / dt)))


def move_time(a: np.ndarray, b: np.ndarray, limits: Limits, minimum_s: float = 0.5) -> float:
    """Shortest minimum-jerk move from ``a`` to ``b`` within the limits: peak velocity
    1.875 d / T, peak acceleration 5.774 d / T^2 per joint, with a 2 % margin (the sampled
    motion's finite differences), rounded up to whole samples."""
    d = np.abs(np.asarray(b) - np.asarray(a))
    t = max(minimum_s, 1.02 * float(np.max(1.875 * d / limits.velocity)),
            1.02 * float(np.max(np.sqrt(5.774 * d / limits.acceleration))))
    return float(np.ceil(t / DT) * DT)


def _move(a: np.ndarray, b: np.ndarray, duration_s: float) -> np.ndarray:
    """Minimum-jerk samples from ``a`` to ``b`` (both included) over ``duration_s``."""
    n = _steps(duration_s) + 1
    return a + (b - a) * min_jerk(np.arange(n) / (n - 1))[:, None]


APPROACH_RAD = 0.1
"""How far beyond a known-weight hold's pose the wrist starts its approach (rad, wrist pitch and
yaw): five times the cables' pre-sliding travel (the prior's ``PRESLIDING_RAD``, 0.02 rad), so
the friction has turned the way the approach moved by the time the hold starts."""
APPROACH_S = 1.0
"""How long a known-weight hold's approach move lasts (s, minimum jerk)."""
_WRIST = (JOINTS.index("wrist_pitch"), JOINTS.index("wrist_yaw"))


def weight_hold(pose: np.ndarray, hold_s: float, approach_rad: float = 0.0, side: int = 1
                ) -> np.ndarray:
    """(N, 7) setpoints at :data:`~psmforce.sim.motion.DT` of one known-weight hold at ``pose``
    (7,). ``approach_rad`` 0: the pose
    for ``hold_s`` from the first sample, the wrist never moved, so the cables' friction has no
    direction. Otherwise the wrist's pitch and yaw start ``side`` (+1 or -1) x ``approach_rad``
    beyond the pose and move into it over :data:`APPROACH_S` before the hold, as an arm moving
    into the pose does: the friction then points the way the approach moved, the sign of which
    ``side`` chooses."""
    pose = np.asarray(pose, dtype=float)
    hold = np.repeat(pose[None], max(1, int(round(hold_s / DT))), 0)
    if approach_rad == 0.0:
        return hold
    if side not in (1, -1):
        raise ValueError(f"side must be +1 or -1, got {side!r}")
    start = pose.copy()
    start[list(_WRIST)] += side * approach_rad
    return np.vstack([_move(start, pose, APPROACH_S)[:-1], hold])


def fourier_segment(rng: np.random.Generator, limits: Limits,
                    duration_s: float = FOURIER_S) -> tuple[np.ndarray, dict]:
    """(N, 7) a Fourier-series motion of every joint about a centre drawn in the box (the jaw
    open), faded in and out over :data:`RAMP_S`; each joint's series scaled down to its position
    room, velocity and acceleration limits (finite differences, 2 % margin)."""
    n = _steps(duration_s)
    t = np.arange(n) * DT
    lo, hi = limits.lower.copy(), limits.upper.copy()
    lo[6] = max(lo[6], JAW_CLOSED_RAD)  # the open jaw: clenching is the clench segments' part
    centre = lo + (hi - lo) * rng.uniform(0.25, 0.75, 7)
    h = np.arange(1, FOURIER_HARMONICS + 1)
    amp = rng.uniform(0.0, 1.0, (7, len(h))) / h  # a falling spectrum: smooth motion
    phase = rng.uniform(0.0, 2 * np.pi, (7, len(h)))
    wave = np.einsum("jh,jht->tj", amp, np.sin(2 * np.pi * h[None, :, None] / duration_s
                                               * t[None, None, :] + phase[:, :, None]))
    ramp = min_jerk(np.minimum(t, t[-1] - t) / RAMP_S)
    wave = wave * ramp[:, None]
    vel, acc = np.gradient(wave, DT, axis=0), np.gradient(np.gradient(wave, DT, axis=0), DT, axis=0)
    room = np.minimum(centre - lo, hi - centre)
    scale = 0.98 * np.min([room / np.max(np.abs(wave), axis=0),
                           limits.velocity / np.max(np.abs(vel), axis=0),
                           limits.acceleration / np.max(np.abs(acc), axis=0)], axis=0)
    return centre + wave * scale, {"centre": centre.tolist()}


def clench_segment(pose: np.ndarray, grip_nm: float, params: InstrumentParams,
                   limits: Limits) -> tuple[np.ndarray, dict] | None:
    """(N, 7) at the arm and wrist ``pose`` (7,): the jaw closes from :data:`JAW_OPEN_RAD` past
    closed to the command that gives ``grip_nm`` per blade on the nominal tool
    (:func:`~psmforce.sim.cables.jaw_command_for_grip`), holds :data:`HOLD_S` and opens again;
    None where that command lies below the jaw's lower limit."""
    t0 = pair_pretension(pose[None, 3], pose[None, 4], params, Effects())[0, 1]
    jaw = float(jaw_command_for_grip(grip_nm, t0, params))
    if jaw < limits.lower[6]:
        return None
    open_, shut = pose.copy(), pose.copy()
    open_[6], shut[6] = JAW_OPEN_RAD, jaw
    q = np.vstack([_move(open_, shut, CLOSE_S), np.repeat(shut[None], _steps(HOLD_S), 0),
                   _move(shut, open_, CLOSE_S)])
    return q, {"grip_nm": float(grip_nm), "jaw_command_rad": jaw,
               "pose": {j: float(x) for j, x in zip(JOINTS[:6], pose[:6])}}


def simulate_excitation(q: np.ndarray, *, dt: float = DT, seed: int = 0,
                        params: InstrumentParams | None = None, effects: Effects | None = None,
                        contact: Contact | None = None, truth: bool = True) -> pd.DataFrame:
    """The bench running setpoints ``q`` (N, 7): :func:`~psmforce.sim.bench.run_trajectory` in
    free space (``contact``: a known weight, say), the nominal tool and every effect by
    default, noise drawn from ``seed``."""
    return run_trajectory(np.asarray(q, float), dt, contact or Contact(),
                          params or InstrumentParams(), effects or Effects(),
                          np.random.default_rng(seed), truth=truth)


def _safe(q: np.ndarray, params: InstrumentParams) -> bool:
    """Whether the noise-free bench keeps the HEX10 above the protocols' safety limit."""
    fz = simulate_excitation(q, params=params, effects=QUIET, truth=False)["fz"].to_numpy()
    return bool(fz.min() > SAFE_COMPRESSION_N)


def candidates(seed: int, duration_s: float, limits: Limits, params: InstrumentParams
               ) -> list[tuple[str, np.ndarray, dict]]:
    """The pool :func:`design` chooses from: Fourier segments for 1.5 times the duration, and a
    clench at each grip level in each of :data:`CLENCH_POSES` poses drawn in the box (wrist
    pitch and yaw within ``WRIST_LIMITS``), kept where the bench stays out of the HEX10's
    overload. Deterministic in ``seed``."""
    rng = np.random.default_rng([seed, 44, 1])
    pool = [("fourier", *fourier_segment(rng, limits))
            for _ in range(int(np.ceil(1.5 * duration_s / FOURIER_S)))]
    lo, hi = limits.lower.copy(), limits.upper.copy()
    lo[4:6], hi[4:6] = WRIST_LIMITS[1:3, 0], WRIST_LIMITS[1:3, 1]
    poses = lo + (hi - lo) * rng.random((CLENCH_POSES, 7))
    for pose in poses:
        for grip in GRIP_LEVELS_NM:
            made = clench_segment(pose, grip, params, limits)
            if made is not None and _safe(made[0], params):
                pool.append(("clench", *made))
    return pool


def design(seed: int, minutes: float, fisher: Callable[[pd.DataFrame], np.ndarray],
           log_det: Callable[[np.ndarray], float], params: InstrumentParams | None = None,
           limits: Limits | None = None) -> Excitation:
    """The excitation of about ``minutes``: from the pool of :func:`candidates`, each run through
    the noise-free bench on its own and scored by ``fisher(frame)`` (an information matrix,
    additive over samples), the candidate with the largest gain of ``log_det`` per second is
    added until the next would not fit (its transition included); then the chosen segments in
    that order, joined by :func:`move_time` transitions after a :data:`SETTLE_S` hold."""
    params = params or InstrumentParams()
    limits = limits or excitation_limits()
    budget = 60.0 * minutes
    pool = candidates(seed, budget, limits, params)
    infos = [fisher(simulate_excitation(q, params=params, effects=QUIET)) for _, q, _ in pool]
    info = REGULARISATION * np.diag(np.diag(sum(infos)))
    chosen: list[int] = []
    used = SETTLE_S
    end = None
    while True:
        fits = [k for k in range(len(pool)) if k not in chosen]
        costs = {k: len(pool[k][1]) * DT + (0.0 if end is None else move_time(end, pool[k][1][0], limits))
                 for k in fits}
        fits = [k for k in fits if used + costs[k] <= budget]
        if not fits:
            break
        base = log_det(info)
        k = max(fits, key=lambda c: (log_det(info + infos[c]) - base) / costs[c])
        chosen.append(k)
        info = info + infos[k]
        used += costs[k]
        end = pool[k][1][-1]
    return assemble([pool[k] for k in chosen], limits, seed)


def assemble(parts: list[tuple[str, np.ndarray, dict]], limits: Limits, seed: int) -> Excitation:
    """One trajectory from ``parts`` (kind, (N, 7) setpoints, spec): a settle hold at the first
    part's start, then each part after a minimum-jerk transition from the previous one's end."""
    pieces, segments = [], []
    t = 0.0

    def add(kind, q, spec):
        nonlocal t
        pieces.append(q)
        segments.append(Segment(kind, round(t, 6), round(len(q) * DT, 6), spec))
        t += len(q) * DT

    add("settle", np.repeat(parts[0][1][:1], _steps(SETTLE_S), 0), {})
    for kind, q, spec in parts:
        prev = pieces[-1][-1]
        if np.any(prev != q[0]):
            add("transition", _move(prev, q[0], move_time(prev, q[0], limits)), {})
        add(kind, q, spec)
    return Excitation(np.vstack(pieces), segments, limits, seed)


def random_motion(seed: int, duration_s: float, limits: Limits) -> np.ndarray:
    """(N, 7) the comparison of a motion without design: random waypoints of every joint drawn
    uniformly in the same box (the jaw open), minimum-jerk moves of 1 to 2 times their shortest
    time within the same limits, holds of 0 to 0.3 s; ``duration_s`` long."""
    rng = np.random.default_rng([seed, 44, 2])
    lo, hi = limits.lower.copy(), limits.upper.copy()
    lo[6] = JAW_CLOSED_RAD
    point = lo + (hi - lo) * rng.random(7)
    pieces = [np.repeat(point[None], _steps(SETTLE_S), 0)]
    n = _steps(duration_s)
    while sum(len(p) for p in pieces) < n:
        nxt = lo + (hi - lo) * rng.random(7)
        pieces.append(_move(point, nxt, move_time(point, nxt, limits) * rng.uniform(1.0, 2.0)))
        pieces.append(np.repeat(nxt[None], _steps(rng.uniform(0.0, 0.3)), 0))
        point = nxt
    return np.vstack(pieces)[:n]


def paper_free_motion(seed: int, duration_s: float) -> list[np.ndarray]:
    """The paper's free-space motion of the same duration: the protocols' continuous random
    free-space trials (:func:`~psmforce.sim.protocols._random_free`, test split, a minute
    each), as separate (N, 7) trials (they do not join at rest). Not held to this module's
    limits: as the protocols move."""
    trials, left, part = [], duration_s, 0
    while left > 0:
        q = _random_free(seed, part, 60.0).q
        trials.append(q[:_steps(min(left, len(q) * DT))])
        left -= len(trials[-1]) * DT
        part += 1
    return trials


def setpoints_frame(q: np.ndarray, dt: float = DT) -> pd.DataFrame:
    """The setpoint CSV's table: time (s) and each joint with its unit (:data:`SETPOINT_COLUMNS`)."""
    data = np.column_stack([np.arange(len(q)) * dt, q])
    return pd.DataFrame(data, columns=list(SETPOINT_COLUMNS))


MAX_SETPOINT_BYTES = 256 << 20
"""The largest setpoint CSV read back (hours of setpoints at 100 Hz)."""


def read_setpoints(path) -> tuple[np.ndarray, float]:
    """(q (N, 7), dt) from a setpoint CSV (:func:`setpoints_frame`'s columns, a regular file,
    uniform time steps); ValueError naming the file otherwise."""
    text = read_input_text(path, MAX_SETPOINT_BYTES, "setpoint CSV")
    try:
        frame = pd.read_csv(io.StringIO(text))
    except (ValueError, pd.errors.ParserError) as err:
        raise ValueError(f"{path}: not a setpoint CSV ({err})") from None
    if tuple(frame.columns) != SETPOINT_COLUMNS:
        raise ValueError(f"{path}: columns must be {', '.join(SETPOINT_COLUMNS)}")
    data = frame.to_numpy(dtype=float)
    step = np.diff(data[:, 0])
    if len(data) < 2 or not np.isfinite(data).all() or not np.allclose(step, step[0], rtol=1e-6) \
            or not step[0] > 0:
        raise ValueError(f"{path}: needs finite values and time in uniform increasing steps")
    return data[:, 1:], float(step[0])
