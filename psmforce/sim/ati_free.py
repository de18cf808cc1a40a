"""The recordings of a lab without an ATI (issue 44), simulated for one bench seed: what
``psmforce calibrate --free-space DIR --known-loads DIR`` reads (docs/ati_free.md).

:func:`simulate_ati_free` writes two dataset folders under ``out`` (layout and units of
:mod:`psmforce.io.recording`; each ``metadata.json`` written last, as :func:`psmforce.sim.simulate`):

* ``free_space/``: ``train/Free`` recordings, first the paper's free-space motion (the automated
  protocol's training free-space replays, :func:`psmforce.sim.protocols.automated`, in order,
  the last cut so that they last ``free_minutes``), then the designed excitation (setpoints
  given: :func:`psmforce.sim.excitation.design` needs the prior's information, which this wing
  does not import), simulated whole and cut into recordings of about :data:`CHUNK_S` (each its
  own trajectory family, so that a validation split takes a part of it, never all of it);
* ``known_loads/``: one ``train/KnownLoad`` recording per (mass, pose) hold, the mass hung at the
  jaw tip (:class:`~psmforce.sim.bench.Contact` ``"weight"``) and held still for ``hold_s``, its
  trial entry carrying ``known_load_kg`` (with ``approach_rad``, each recording starts with the
  wrist's move into the pose); a hold that takes the HEX10 to the protocols' safety
  limit (:data:`~psmforce.sim.protocols.SAFE_COMPRESSION_N`) is left out and listed.

No recording carries ATI columns (the lab has none); every one is simulated on the same
instrument (``instrument``, or a drawn tool ``instrument.sample(tool_seed, tool_spread)``) with
every effect on, noise from ``[seed, 144, part, index]``. The metadata's trial entries say what
each recording is (``kind``: ``paper_free``, ``excitation`` or ``known_load``).
"""

from __future__ import annotations

import json
import time
from pathlib import Path

import numpy as np

import psmforce.sim.protocols as protocols

from psmforce.core.files import folder_is_empty, locked_folder, write_text_atomic
from psmforce.io.recording import ATI_RAW, TARGETS, TIME, write_recording
from psmforce.robot.conventions import GRAVITY_UPRIGHT_MPS2
from psmforce.sim.bench import Contact, run_trajectory
from psmforce.sim.dataset import SIM_VERSION, SimulationConfigError, check_scale_and_seed
from psmforce.sim.excitation import weight_hold
from psmforce.sim.params import Effects, InstrumentParams

FREE_SPACE, KNOWN_LOADS = "free_space", "known_loads"
"""The two folders :func:`simulate_ati_free` writes under ``out``."""
CHUNK_S = 30.0
"""The excitation's recordings last about this long (the last one takes the remainder)."""
KNOWN_LOAD_CONDITION = "KnownLoad"


def _rows(seconds: float) -> int:
    return int(round(seconds / protocols.DT))


def paper_free_plans(scale: float, seed: int, free_minutes: float) -> list[tuple[str, np.ndarray]]:
    """(name, (N, 7) setpoints) of the automated protocol's training free-space replays, in
    order, the last cut so that they last ``free_minutes`` in all."""
    left = _rows(60.0 * free_minutes)
    out = []
    for plan in protocols.automated(scale, seed):
        if left <= 0:
            break
        if (plan.split, plan.condition) != ("train", "Free"):
            continue
        q = plan.q[:left]
        out.append((Path(plan.path).stem, q))
        left -= len(q)
    if left > 0:
        raise SimulationConfigError(
            f"free_minutes: the protocol at scale {scale:g} holds "
            f"{sum(len(q) for _, q in out) * protocols.DT / 60:.2f} min of free-space motion, "
            f"{free_minutes:g} asked")
    return out


def excitation_chunks(n_rows: int, chunk_s: float = CHUNK_S) -> list[tuple[int, int]]:
    """(start, stop) rows cutting ``n_rows`` into pieces of ``chunk_s``; a remainder shorter
    than half a piece joins the last one."""
    size = _rows(chunk_s)
    starts = np.arange(0, n_rows, size)
    if len(starts) > 1 and n_rows - starts[-1] < size / 2:
        starts = starts[:-1]
    stops = np.r_[starts[1:], n_rows]
    return list(zip(starts.tolist(), stops.tolist()))


def _recording(q, contact, params, effects, rng):
    frame = run_trajectory(q, protocols.DT, contact, params, effects, rng,
                           r_base_ati=protocols.R_BASE_ATI, truth=False)
    return frame.drop(columns=[c for c in TARGETS + ATI_RAW if c in frame.columns])


def _write_folder(path: Path, entries: list[tuple[str, object, dict]], common: dict) -> None:
    """Write each (relative path, frame, metadata entry) and then metadata.json."""
    path.mkdir(parents=True, exist_ok=True)
    with locked_folder(path):
        if not folder_is_empty(path):
            raise SimulationConfigError(f"out: {path} is not empty (refusing to mix datasets)")
        for rel, frame, _ in entries:
            target = path / rel
            target.parent.mkdir(parents=True, exist_ok=True)
            write_recording(frame, target)
        trials = [{"path": rel, "split": "train", **entry, "rows": len(frame)}
                  for rel, frame, entry in entries]
        write_text_atomic(path / "metadata.json", json.dumps({**common, "trials": trials},
                                                             indent=1))


def simulate_ati_free(out, *, seed: int, scale: float, free_minutes: float,
                      excitation_q: np.ndarray | None = None,
                      weight_poses: dict[str, np.ndarray] | None = None, masses_kg=(),
                      hold_s: float = 10.0, instrument: InstrumentParams | None = None,
                      tool_seed: int | None = None, tool_spread: float = 1.0,
                      effects: Effects | None = None, approach_rad: float = 0.0) -> dict:
    """Write ``out/free_space`` and, with ``masses_kg`` and ``weight_poses`` (label -> (7,)
    pose), ``out/known_loads`` (module docstring). ``excitation_q``: the excitation's setpoints
    (N, 7) at the protocols' rate, or None for the paper's motion alone. ``approach_rad``: each
    hold's recording starts with the wrist that far beyond the pose and moves into it
    (:func:`psmforce.sim.excitation.weight_hold`), from one side at one mass and from the other
    at the next, so the cables' friction points both ways across the holds; 0: hung from rest.
    Returns a summary: minutes per kind, the holds left out, seconds taken."""
    check_scale_and_seed(scale, seed)
    out = Path(out)
    start = time.perf_counter()
    params = instrument or InstrumentParams()
    tool = None
    if tool_seed is not None:
        params = params.sample(tool_seed, tool_spread)
        tool = {"seed": int(tool_seed), "spread": float(tool_spread)}
    effects = effects or Effects()
    common = {"simulator_version": SIM_VERSION, "generator": "psmforce.sim.ati_free",
              "protocol": "ati_free", "scale": float(scale), "seed": int(seed),
              "sample_rate_hz": 1.0 / protocols.DT, "instrument": params.to_dict(),
              **({} if tool is None else {"tool": tool}), "effects": effects.to_dict(),
              "gravity_base": list(GRAVITY_UPRIGHT_MPS2), "ati": "none: no ATI columns"}
    free = []
    for k, (name, q) in enumerate(paper_free_plans(scale, seed, free_minutes)):
        frame = _recording(q, Contact(), params, effects, np.random.default_rng([seed, 144, 0, k]))
        free.append((f"train/Free/paper_{name}.csv", frame,
                     {"condition": "Free", "kind": "paper_free", "group": f"paper_{name}"}))
    if excitation_q is not None:
        frame = _recording(np.asarray(excitation_q, float), Contact(), params, effects,
                           np.random.default_rng([seed, 144, 1, 0]))
        for k, (a, b) in enumerate(excitation_chunks(len(frame))):
            piece = frame.iloc[a:b].reset_index(drop=True)
            piece[TIME] = piece[TIME] - piece[TIME].iat[0]
            free.append((f"train/Free/excitation_{k:02d}.csv", piece,
                         {"condition": "Free", "kind": "excitation", "group": f"excitation_{k}",
                          "excitation_rows": [a, b]}))
    _write_folder(out / FREE_SPACE, free, common)
    minutes = {kind: sum(len(f) for _, f, e in free if e["kind"] == kind) * protocols.DT / 60
               for kind in ("paper_free", "excitation")}
    left_out = []
    if masses_kg and weight_poses:
        holds, index = [], 0
        for mass_index, mass in enumerate(masses_kg):
            for pose_index, (label, pose) in enumerate(weight_poses.items()):
                # each pose approached from one side at one mass and the other at the next
                q = weight_hold(pose, hold_s, approach_rad,
                                1 if (mass_index + pose_index) % 2 == 0 else -1)
                frame = _recording(q, Contact(kind="weight", mass_kg=float(mass)), params,
                                   effects, np.random.default_rng([seed, 144, 2, index]))
                index += 1
                if frame["fz"].min() <= protocols.SAFE_COMPRESSION_N:
                    left_out.append(f"{float(mass):g} kg, {label}")
                    continue
                holds.append((f"train/{KNOWN_LOAD_CONDITION}/load_{len(holds):02d}.csv", frame,
                              {"condition": KNOWN_LOAD_CONDITION, "kind": "known_load",
                               "known_load_kg": float(mass), "pose": label,
                               "group": f"load_{len(holds):02d}"}))
        _write_folder(out / KNOWN_LOADS, holds, {**common, "hold_s": float(hold_s), **(
            {"approach_rad": float(approach_rad)} if approach_rad else {})})
        minutes["known_load"] = sum(len(f) for _, f, _ in holds) * protocols.DT / 60
    return {"out": str(out), "minutes": {k: round(v, 4) for k, v in minutes.items()},
            "left_out_unsafe": left_out, "seconds": round(time.perf_counter() - start, 2)}
