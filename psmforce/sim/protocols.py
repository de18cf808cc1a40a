"""The paper's data-collection protocols as commanded joint trajectories (one plan per trial).

Automated benchtop (paper Tables "Factorial design" and "Automated dataset composition"):
traction (phi 6 x theta 3 x force 3 x wrist configurations, 2 trials), palpation (phi 6 x theta 3 x
3 silicones, a new wrist configuration before each approach from 5 cm to a point 8 mm below the
top of the silicone cylinder),
free space replaying both, and a test set (15 / 9 configurations, continuous random free-space
states at phi = theta = 0). Teleoperation: three PSM configurations with large yaw/pitch,
rigid / soft / free, three human-like demonstrations each.

Geometry (base = RCM frame, upright bench, z up, shaft pointing down at q = 0): the ATI and its
fixtures sit 0.19 m below the RCM. ``scale`` shrinks every protocol proportionally: the number of
(phi, theta) cells and of wrist configurations per trial (automated), the free-space test and the
demonstration durations (teleop). Moves and inverse kinematics: :mod:`.motion`.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field

import numpy as np

from psmforce.sim.bench import Contact, run_trajectory
from psmforce.sim.motion import (DT, WRIST_PITCH_OFFSET_M, WRIST_TO_TIP_M, arm_ik_for_tip,
                                 arm_ik_for_wrist, piecewise, shaft_direction)
from psmforce.sim.params import Effects, InstrumentParams

PHI_DEG = (0.0, 60.0, 120.0, 180.0, 240.0, 300.0)
THETA_DEG = (0.0, 45.0, 90.0)
TRACTION_EXTENSION_M = (0.0, 0.01, 0.02)
"""Spring extension of the three force levels (paper: 0 / 1 / 2 cm; 0, 1.5, 3.1 N at a straight
wrist; wrist motion moves the hook and changes the load)."""
PALPATION_MATERIALS = ("shore_22a", "shore_8a", "shore_00_10")
FIXTURE_DEPTH_M = 0.19
"""Anchor / reference point height below the RCM."""
STRING_REST_M = 0.06
"""String + unstretched spring length between jaw-tip hook and D-ring."""
APPROACH_M = 0.05
PALPATION_DEPTH_M = 0.008
"""Paper: the palpation reference point is 8 mm below the silicone's top surface, on the approach
vector drawn from the centre of the ATI; the tip starts 5 cm from it along that vector."""
BLOCK_RADIUS_M = 0.0085
"""The cylindrical silicone interfaces, cast to the Nano17's 17 mm diameter (**assumed**)."""
WRIST_LIMITS = np.array([[-2.5, 2.5], [-1.0, 1.0], [-1.0, 1.0], [0.0, 0.8]])
"""Sampling box of (roll, wrist_pitch, wrist_yaw, jaw), rad: inside the dVRK limits."""
TRACTION_WRIST_LIMITS = np.array([[-2.5, 2.5], [-0.6, 0.6], [-0.6, 0.6], [0.0, 0.8]])
"""Narrower wrist pitch/yaw under traction: the hook on the jaw tip moves less, so the load stays
near the level's value and the shaft compression below the HEX10 overload (as the paper's
operators had to ensure)."""
R_BASE_ATI = np.array([[np.cos(0.5), -np.sin(0.5), 0.0], [np.sin(0.5), np.cos(0.5), 0.0], [0.0, 0.0, 1.0]])
"""ATI frame in the base frame (z up, clocked 0.5 rad): the fixture calibration."""

# Timing (s) chosen so that the full-scale split durations follow the paper's Table (see docs).
TRACTION_MOVE, TRACTION_HOLD = 0.5, 0.9
TEST_TRACTION_MOVE, TEST_TRACTION_HOLD = 0.55, 1.1
PALP_WRIST, PALP_APPROACH, PALP_DWELL = 0.4, 1.1, 0.4
TEST_PALP_WRIST, TEST_PALP_APPROACH, TEST_PALP_DWELL = 0.33, 0.9, 0.4
SETTLE = 1.0
ARM_MOVE = 2.0
TEST_FREE_S = 600.0
TEST_FREE_TRIALS_PER_MIN = 1.0
"""The continuous random free-space test is cut into trials of about a minute (at least 3), so
the free-space condition has several test trials for a spread at every scale."""
TELEOP_DEMO_S = 120.0
TELEOP_SETTLE_S = 2.0
"""Teleoperation demos start held still in free space this long: the evaluation's bias window
(samples 99-148, :mod:`psmforce.estimators.evaluation.evaluate`) must lie before the first contact, with margin."""
TELEOP_CONFIGS = ((0.75, 0.45, 0.17), (-0.70, 0.50, 0.16), (0.35, -0.65, 0.18))
"""(yaw, pitch, insertion) of the three teleoperation PSM configurations."""


@dataclass
class Plan:
    """One trial to simulate: commanded joints (N, 7) and what the tip touches."""

    path: str
    split: str
    condition: str
    q: np.ndarray
    contact: Contact
    info: dict = field(default_factory=dict)


def _unit(phi_deg: float, theta_deg: float) -> np.ndarray:
    ph, th = np.deg2rad(phi_deg), np.deg2rad(theta_deg)
    return np.array([np.cos(th) * np.cos(ph), np.cos(th) * np.sin(ph), np.sin(th)])


def _configs(rng: np.random.Generator, n: int, limits: np.ndarray = WRIST_LIMITS) -> np.ndarray:
    lo, hi = limits[:, 0], limits[:, 1]
    return lo + (hi - lo) * rng.random((n, 4))


ANCHOR = np.array([0.0, 0.0, -FIXTURE_DEPTH_M])
SAFE_COMPRESSION_N = -80.0
"""Wrist configurations whose static HEX10 reading under the trial's load would be below this are
redrawn, as the paper's operators shaped their protocol to keep the sensor out of overload (the
compression came within 15 N of it). Screened with the full noise-free model, each candidate
reached from two opposite sides (friction direction); moves between configurations can still
pass a few samples beyond."""


def _safe_configs(rng: np.random.Generator, n: int, limits: np.ndarray, static_q, contact) -> np.ndarray:
    """``n`` wrist configurations whose static loaded HEX10 fz stays above SAFE_COMPRESSION_N.
    ``static_q(configs)`` gives the (K, 7) joints holding each configuration under the load."""
    quiet = dataclasses.replace(Effects(), sensor_noise=False, hex10_drift=False, encoder_quantisation=False,
                                coloured_effort_noise=False, remount_offsets=False)
    kept = []
    for _ in range(20):
        candidates = _configs(rng, 2 * n, limits)
        q = static_q(candidates)
        worst = np.full(len(q), np.inf)
        for order in (np.arange(len(q)), np.arange(len(q))[::-1]):
            fz = run_trajectory(q[order], DT, contact, InstrumentParams(), quiet, rng, truth=False).fz.to_numpy()
            worst[order] = np.minimum(worst[order], fz)
        kept.extend(candidates[worst > SAFE_COMPRESSION_N])
        if len(kept) >= n:
            break
    if len(kept) < n:
        raise RuntimeError(f"could not find {n} wrist configurations within the HEX10 safety limit")
    return np.array(kept[:n])


def _traction_arm(phi, theta, level):
    """Arm joints that put the straight-wrist jaw tip at the anchor + (rest + extension) u."""
    tip = ANCHOR + (STRING_REST_M + TRACTION_EXTENSION_M[level]) * _unit(phi, theta)
    wrist = tip.copy()
    for _ in range(8):  # the shaft direction depends on where the wrist is
        q = arm_ik_for_wrist(wrist[None, :])[0]
        wrist = tip - WRIST_TO_TIP_M * shaft_direction(q[0], q[1])
    return arm_ik_for_wrist(wrist[None, :])[0]


def _wrist_sequence(configs, move, hold):
    k = len(configs)
    way = np.vstack([configs[:1], configs])
    return piecewise(way, np.r_[0.0, np.full(k - 1, move)], np.r_[SETTLE, np.full(k - 1, hold)])


def traction_q(phi, theta, level, configs, move, hold) -> np.ndarray:
    wrist = _wrist_sequence(configs, move, hold)
    q = np.zeros((len(wrist), 7))
    q[:, :3] = _traction_arm(phi, theta, level)
    q[:, 3:] = wrist
    return q


def _traction_static(phi, theta, level):
    arm = _traction_arm(phi, theta, level)
    return lambda configs: np.column_stack([np.tile(arm, (len(configs), 1)), configs])


def _palpation_reference() -> np.ndarray:
    return ANCHOR - np.array([0.0, 0.0, PALPATION_DEPTH_M])


def _palpation_static(phi, theta):
    bottom = _palpation_reference()
    return lambda configs: arm_ik_for_tip(np.tile(bottom, (len(configs), 1)), configs)


def traction_contact() -> Contact:
    return Contact(kind="traction", anchor=ANCHOR.copy(), rest_length=STRING_REST_M,
                   ati_origin=ANCHOR - np.array([0.0, 0.0, 0.03]))


def palpation_q(phi, theta, configs, t_wrist, t_app, t_dwell) -> np.ndarray:
    bottom = _palpation_reference()
    retract = bottom + APPROACH_M * _unit(phi, theta)
    tips, wrists = [], []
    prev = configs[0]
    settle = int(round(SETTLE / DT))
    tips.append(np.repeat(retract[None], settle, 0))
    wrists.append(np.repeat(prev[None], settle, 0))
    move = np.array([t_wrist, t_app, 0.0, t_app])
    hold = np.array([0.0, 0.0, t_dwell, 0.0])
    for c in configs:
        wrists.append(piecewise(np.vstack([prev, c, c, c, c]), move, hold))
        tips.append(piecewise(np.vstack([retract, retract, bottom, bottom, retract]), move, hold))
        prev = c
    return arm_ik_for_tip(np.concatenate(tips), np.concatenate(wrists))


def palpation_contact(material: str, phi: float, theta: float) -> Contact:
    """The face of the cylindrical block (top at ANCHOR) that the approach enters: the top if the
    ray from the reference point along u(phi, theta) rises 8 mm within the block's radius, else
    the side wall facing the approach (a 0 deg elevation presses the cylinder sideways)."""
    u = _unit(phi, theta)
    across = np.hypot(u[0], u[1])
    if PALPATION_DEPTH_M * across < BLOCK_RADIUS_M * u[2]:
        point, normal = ANCHOR.copy(), np.array([0.0, 0.0, 1.0])
    else:
        normal = np.array([u[0], u[1], 0.0]) / across
        point = _palpation_reference() + BLOCK_RADIUS_M * normal
    return Contact(kind="surface", point=point, normal=normal,
                   material=material, ati_origin=ANCHOR - np.array([0.0, 0.0, 0.02]))


def _grid(scale: float, rng: np.random.Generator) -> tuple[list[tuple[int, int]], float]:
    """(phi, theta) cells kept at this scale and the wrist-configuration multiplier."""
    cells = [(i, j) for i in range(len(PHI_DEG)) for j in range(len(THETA_DEG))]
    keep = int(min(len(cells), max(1, round(len(cells) * np.sqrt(scale)))))
    chosen = sorted(rng.choice(len(cells), size=keep, replace=False).tolist())
    return [cells[c] for c in chosen], scale * len(cells) / keep


def automated(scale: float, seed: int) -> list[Plan]:
    """All trials of the automated protocol (train = train + validation pool, and test)."""
    grid_rng = np.random.default_rng([seed, 1])
    cells, mult = _grid(scale, grid_rng)
    n_train = max(2, int(round(25 * mult)))
    n_test_trac = max(2, int(round(15 * mult)))
    n_test_palp = max(2, int(round(9 * mult)))
    plans: list[Plan] = []
    for (i, j) in cells:
        phi, theta = PHI_DEG[i], THETA_DEG[j]
        base_info = {"phi_deg": phi, "theta_deg": theta}
        tag = f"phi{int(phi):03d}_theta{int(theta):02d}"
        # --- training pool ---
        free_trac_q = []
        for level in range(3):
            for rep in range(2):
                rng = np.random.default_rng([seed, 2, i, j, level, rep])
                configs = _safe_configs(rng, n_train, TRACTION_WRIST_LIMITS,
                                        _traction_static(phi, theta, level), traction_contact())
                q = traction_q(phi, theta, level, configs, TRACTION_MOVE, TRACTION_HOLD)
                plans.append(Plan(f"train/Traction/{tag}_f{level}_r{rep}.csv", "train", "Traction", q,
                                  traction_contact(),
                                  {**base_info, "force_level": level, "trial": rep,
                                   "group": f"{tag}_traction_r0" if rep == 0
                                   else f"{tag}_f{level}_r{rep}",
                                   "extension_m": TRACTION_EXTENSION_M[level],
                                   "wrist_configs": configs.tolist()}))
                if rep == 0:
                    free_trac_q.append(q)
        palp_q0 = None
        for m, material in enumerate(PALPATION_MATERIALS):
            rng = np.random.default_rng([seed, 3, i, j, m])
            configs = _safe_configs(rng, n_train, WRIST_LIMITS, _palpation_static(phi, theta),
                                    palpation_contact(material, phi, theta))
            q = palpation_q(phi, theta, configs, PALP_WRIST, PALP_APPROACH, PALP_DWELL)
            palp_q0 = q if palp_q0 is None else palp_q0
            plans.append(Plan(f"train/Palpation/{tag}_{material}.csv", "train", "Palpation", q,
                              palpation_contact(material, phi, theta),
                              {**base_info, "material": material, "trial": m,
                               "group": f"{tag}_palpation_{PALPATION_MATERIALS[0]}" if m == 0
                               else f"{tag}_{material}",
                               "wrist_configs": configs.tolist()}))
        # Free space replays the same joint trajectories with the fixture removed; "group" names
        # the trajectory family so validation never splits a replay from what it replays.
        arm_moves = []
        for level, q in enumerate(free_trac_q):
            if level:
                prev = free_trac_q[level - 1][-1]
                arm_moves.append(piecewise(np.vstack([prev, q[0]]), np.array([ARM_MOVE]), np.array([0.0])))
            arm_moves.append(q)
        plans.append(Plan(f"train/Free/{tag}_traction.csv", "train", "Free", np.concatenate(arm_moves),
                          Contact(), {**base_info, "replays": "Traction",
                                      "group": f"{tag}_traction_r0"}))
        plans.append(Plan(f"train/Free/{tag}_palpation.csv", "train", "Free", palp_q0, Contact(),
                          {**base_info, "replays": "Palpation",
                           "group": f"{tag}_palpation_{PALPATION_MATERIALS[0]}"}))
        # --- test set ---
        for level in range(3):
            rng = np.random.default_rng([seed, 4, i, j, level])
            configs = _safe_configs(rng, n_test_trac, TRACTION_WRIST_LIMITS,
                                    _traction_static(phi, theta, level), traction_contact())
            q = traction_q(phi, theta, level, configs, TEST_TRACTION_MOVE, TEST_TRACTION_HOLD)
            plans.append(Plan(f"test/Traction/{tag}_f{level}.csv", "test", "Traction", q, traction_contact(),
                              {**base_info, "force_level": level, "extension_m": TRACTION_EXTENSION_M[level],
                               "wrist_configs": configs.tolist()}))
        for m, material in enumerate(PALPATION_MATERIALS):
            rng = np.random.default_rng([seed, 5, i, j, m])
            configs = _safe_configs(rng, n_test_palp, WRIST_LIMITS, _palpation_static(phi, theta),
                                    palpation_contact(material, phi, theta))
            q = palpation_q(phi, theta, configs, TEST_PALP_WRIST, TEST_PALP_APPROACH, TEST_PALP_DWELL)
            plans.append(Plan(f"test/Palpation/{tag}_{material}.csv", "test", "Palpation", q,
                              palpation_contact(material, phi, theta),
                              {**base_info, "material": material, "wrist_configs": configs.tolist()}))
    duration = TEST_FREE_S * scale
    n_free = max(3, int(round(duration / 60.0 * TEST_FREE_TRIALS_PER_MIN)))
    plans += [_random_free(seed, part, max(5.0, duration / n_free)) for part in range(n_free)]
    return plans


def _random_free(seed: int, part: int, duration: float) -> Plan:
    rng = np.random.default_rng([seed, 6, part])
    moves = []
    total = 0.0
    while total < duration:
        moves.append(rng.uniform(0.4, 2.5))
        total += moves[-1]
    k = len(moves)
    configs = _configs(rng, k + 1)
    wrist = piecewise(configs, np.array(moves), rng.uniform(0.0, 0.3, k))
    wrist = np.vstack([np.repeat(wrist[:1], int(SETTLE / DT), 0), wrist])
    q = np.zeros((len(wrist), 7))
    q[:, :3] = _traction_arm(0.0, 0.0, 1)
    q[:, 3:] = wrist
    return Plan(f"test/Free/random_states_{part}.csv", "test", "Free", q, Contact(),
                {"phi_deg": 0.0, "theta_deg": 0.0, "replays": "continuous random states"})


# --- teleoperation ---

TELEOP_CONDITIONS = {"Rigid": ("rigid", 0.0022), "Soft": ("shore_8a", 0.012), "Free": (None, 0.005)}
"""condition: (material, deepest press in m)."""


def _teleop_actions(rng: np.random.Generator, duration: float, depth_max: float):
    """Tip offsets (lateral x, y, height z above the surface) and wrist waypoints with durations:
    press, drag, wrist rotation under load, quick pokes, reposition; random order and speeds."""
    way = [np.array([0.0, 0.0, 0.015])]
    wrist = [np.array([0.0, 0.0, 0.0, 0.3])]
    move, hold = [], []
    total = 0.0

    def add(p, w, t_move, t_hold):
        nonlocal total
        way.append(p)
        wrist.append(w)
        move.append(t_move)
        hold.append(t_hold)
        total += t_move + t_hold

    while total < duration:
        action = rng.choice(["press", "drag", "rotate", "poke", "reposition"])
        here = way[-1].copy()
        w = wrist[-1].copy()
        depth = -depth_max * rng.uniform(0.3, 1.0)
        speed = rng.uniform(0.6, 1.6)
        if action == "press":
            add(np.r_[here[:2], depth], w, 1.0 / speed, rng.uniform(0.3, 1.5))
            add(np.r_[here[:2], 0.01], w, 0.8 / speed, 0.2)
        elif action == "drag":
            add(np.r_[here[:2], depth], w, 0.8 / speed, 0.2)
            target = np.clip(here[:2] + rng.uniform(-0.015, 0.015, 2), -0.015, 0.015)
            add(np.r_[target, depth], w, 2.0 / speed, 0.2)
            add(np.r_[target, 0.01], w, 0.8 / speed, 0.1)
        elif action == "rotate":
            add(np.r_[here[:2], depth], w, 0.8 / speed, 0.1)
            for _ in range(2):
                w2 = np.clip(w + rng.uniform(-0.6, 0.6, 4) * [1.0, 1.0, 1.0, 0.5], WRIST_LIMITS[:, 0], WRIST_LIMITS[:, 1])
                add(np.r_[here[:2], depth], w2, 1.2 / speed, 0.2)
            add(np.r_[here[:2], 0.01], wrist[-1], 0.8 / speed, 0.1)
        elif action == "poke":
            for _ in range(3):
                add(np.r_[here[:2], depth], w, 0.35 / speed, 0.05)
                add(np.r_[here[:2], 0.004], w, 0.35 / speed, 0.05)
        else:
            target = rng.uniform(-0.015, 0.015, 2)
            w2 = _configs(rng, 1)[0] * [0.6, 0.6, 0.6, 1.0]
            add(np.r_[target, rng.uniform(0.005, 0.025)], w2, rng.uniform(1.0, 2.5), rng.uniform(0.0, 0.5))
    return np.array(way), np.array(wrist), np.array(move), np.array(hold)


def teleop(scale: float, seed: int) -> list[Plan]:
    plans = []
    duration = max(4.0, TELEOP_DEMO_S * scale)
    for c, (yaw, pitch, ins) in enumerate(TELEOP_CONFIGS):
        work = ((ins - WRIST_PITCH_OFFSET_M + WRIST_TO_TIP_M)
                * shaft_direction(np.array(yaw), np.array(pitch)))
        for cond, (material, depth_max) in TELEOP_CONDITIONS.items():
            for k in range(3):
                rng = np.random.default_rng([seed, 7, c, list(TELEOP_CONDITIONS).index(cond), k])
                way, wrist_way, move, hold = _teleop_actions(rng, duration, depth_max)
                off = piecewise(way, move, hold)
                wrist = piecewise(wrist_way, move, hold)
                settle = int(round(TELEOP_SETTLE_S / DT))
                off = np.vstack([np.repeat(off[:1], settle, 0), off])
                wrist = np.vstack([np.repeat(wrist[:1], settle, 0), wrist])
                q = arm_ik_for_tip(work + off, wrist)
                contact = (Contact() if material is None else
                           Contact(kind="surface", point=work.copy(), normal=np.array([0.0, 0.0, 1.0]),
                                   material=material, ati_origin=work - np.array([0.0, 0.0, 0.02])))
                plans.append(Plan(f"config_{c}/{cond}/demo_{k}.csv", f"config_{c}", cond, q, contact,
                                  {"config": c, "arm_yaw": yaw, "arm_pitch": pitch, "demo": k,
                                   "material": material}))
    return plans
