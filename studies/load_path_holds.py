"""The law at the bench's own parameters on the hung weights' holds, read through the load path as
each change to that reading left it (issue 44, docs/ati_free.md section 4.1).

Per bench seed of :mod:`studies.ati_free_identification` (its drawn tool and recordings, kept
under its ``--work``), on the holds of its two paired cases (the three masses in the sixteen
paired orientations, hung from rest and approached by a move): the law with every parameter at
the bench's truth (:func:`~psmforce.experiments.prior_recovery.default_bench_truth`), and each
hold's settled residual (the mean of the HEX10's internal wrench minus the law over the second
half of its samples that the reading keeps), for each reading in :data:`READINGS`, cumulative:

* ``before``: the encoders' pose, a jaw below 0 rad clenched (a strict comparison with closed),
  the pins' friction carried by the capstan (the law before ``pin_friction``: its truth then the
  idlers' and the pins' sum, its growth terms scaled by the idlers' share);
* ``closed jaw kept``: a jaw within ``load_path.CLENCH_TOLERANCE_RAD`` of closed is closed;
* ``wrist sag``: the tip force's moments where the wrist sags (``load_path.sagged_positions``);
* ``pins``: the law's own pin term at the pins' truth, the capstan at the idlers';
* ``path as pretension``: the blade cables' path tension as their pretension
  (``pitch_path_pretension``), which a slack pair loses, instead of added outside the pairs
  (``pitch_path_tension`` held at 0): today's reading (``prior.fit_arrays``, the load path's
  holds).

Then :data:`FRICTION_SAG`: today's reading with the friction in the sag
(:class:`~psmforce.identification.load_path.WristCompliance` with the tool's capstan, its growth
and its pins at their truth, the rest at the design values): the sag taken from the section's
differential, where the load path's takes its pulleys' (its friction at the design value 0),
what a fit that reads its own friction back into the sag would use. And one diagnostic,
:data:`BENCH_SAG`: today's reading with the wrist sagged as the bench sags it (:func:`bench_sag`: the bench's own transmission for the drawn tool, friction state,
capstan, pins and its cable stiffness included), where the load path's sag takes the pulleys'
differential with the design values and no friction. What it removes is what the sag's model
leaves; it is not a reading a lab has.

No fit: what each reading leaves between the bench and its own law, the part of a fit's residual
that no parameter can remove. Usage::

    python studies/load_path_holds.py --json results/benchmarks/load_path_holds.json
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

READINGS = ("before", "closed jaw kept", "wrist sag", "pins", "path as pretension")
"""The load path's readings, each with the changes of the ones before it (module docstring)."""
FRICTION_SAG = "friction in the sag"
"""The last reading with the tool's friction in the sag (module docstring)."""
BENCH_SAG = "the bench's own sag (diagnostic)"
"""The last reading with the bench's sag in place of the load path's (module docstring)."""
CASES = ("0.05, 0.1, 0.2 kg, 16 paired poses", "0.05, 0.1, 0.2 kg, 16 paired poses, approached")
"""The cases of :mod:`studies.ati_free_identification` whose holds are scored."""
CHANNELS = {"fz": 2, "tx": 3, "ty": 4}


def _law(truth: dict, reading: str):
    """The law at the bench's truth as ``reading`` holds it."""
    import numpy as np

    from psmforce.experiments.prior_recovery import effective_truth
    from psmforce.identification.prior import InternalForcePrior
    from psmforce.identification.prior_law import NAMES, PARAMETERS
    values = {n: truth[n] if truth.get(n) is not None else p[4] for n, p in zip(NAMES, PARAMETERS)}
    # one path tension: outside the pairs before its pretension form, as pretension after it
    values[("pitch_path_pretension" if reading != READINGS[-1] else "pitch_path_tension")] = 0.0
    if reading not in READINGS[3:]:  # the law before its pin term: the capstan carries both
        rows = {n: {"truth": truth.get(n), "fitted": values[n], "status": "identified"}
                for n in NAMES}
        rows["pin_friction"].update(fitted=0.0, status="fixed")
        values.update(effective_truth(rows), pin_friction=0.0)
    return InternalForcePrior(params=np.array([values[n] for n in NAMES]),
                              info={"inputs": "load_path"})


def bench_sag(tool):
    """(q (N, 7), tip force (N, 3), HEX10 frame) -> q with the wrist where the bench's elastic
    cables put it under that force for instrument ``tool`` (:func:`psmforce.sim.cables.
    transmission` with every effect on, as the ATI-free recordings are simulated), the efforts
    taken at the encoders' pose: the load path's :func:`~psmforce.identification.load_path.
    sagged_positions` with the bench's own law."""
    import numpy as np

    from psmforce.identification.load_path import wrist_efforts_for_tip_force
    from psmforce.robot.conventions import wrist_torques_to_distal
    from psmforce.sim.cables import transmission
    from psmforce.sim.params import Effects

    def sagged(q, force):
        q = np.array(q, dtype=float)
        e = wrist_efforts_for_tip_force(q, force)
        demand = np.stack(wrist_torques_to_distal(e[:, 0], e[:, 1], e[:, 2]), axis=1)
        q[:, 4:6] -= transmission(q, -demand, tool, Effects())["deflection"][:, :2]
        return q
    return sagged


def friction_sag(truth: dict):
    """(q, tip force) -> q sagged by the load path with the friction of ``truth`` (the law's
    values, :func:`~psmforce.experiments.prior_recovery.default_bench_truth`) and the design
    values otherwise (:data:`FRICTION_SAG`)."""
    import dataclasses

    from psmforce.identification.load_path import WristCompliance, sagged_positions
    compliance = dataclasses.replace(
        WristCompliance.design(), capstan_mu=truth["capstan_mu"],
        capstan_pitch_gain=truth["capstan_pitch_gain"],
        capstan_roll_gain=truth["capstan_roll_gain"], pin_friction=truth["pin_friction"])
    return lambda q, force: sagged_positions(q, force, compliance)


def hold_residuals(frame, law, reading: str, sagged=None) -> dict | None:
    """One hold's settled residual per channel of :data:`CHANNELS` (N, Nm) under ``reading``,
    None where the reading keeps fewer than 10 of its samples; ``sagged``: the wrist's sag in
    place of the load path's (:func:`bench_sag`)."""
    import numpy as np

    from psmforce.identification.load_path import (clenched, sagged_positions, tip_force_moment,
                                                   wrist_efforts_for_tip_force)
    from psmforce.identification.prior import arrays_from_frame, internal_wrench_target
    from psmforce.io.recording import JOINT_POSITIONS, TARGETS
    q = frame[list(JOINT_POSITIONS)].to_numpy(dtype=float)
    force = frame[list(TARGETS)].to_numpy(dtype=float)
    at = q if reading in READINGS[:2] else (sagged or sagged_positions)(q, force)
    a = arrays_from_frame(frame)
    y, mask = internal_wrench_target(frame)
    y[:, 3:] -= tip_force_moment(at, force)
    mask[:, 3:] = mask[:, :1]
    mask[(q[:, 6] < 0.0) if reading == "before" else clenched(frame)] = 0.0
    pred = law.law_arrays(a["positions"], wrist_efforts_for_tip_force(at, force),
                          a["velocities"], a["g_hex"], a["direction"],
                          a["hex10_force"] if law.has_crosstalk else None)
    kept = np.flatnonzero(mask[:, 2] > 0)
    if len(kept) < 10:
        return None
    settled = kept[len(kept) // 2:]
    return {c: float((y[settled, k] - pred[settled, k]).mean()) for c, k in CHANNELS.items()}


def _seed(seed: int, args, q_exc) -> list[dict]:
    import numpy as np

    from psmforce.experiments.prior_recovery import default_bench_truth
    from psmforce.sim.params import InstrumentParams
    from studies.ati_free import TOOL_SEED_OFFSET
    from studies.ati_free_identification import case_recordings
    tool = InstrumentParams().sample(TOOL_SEED_OFFSET + seed, 1.0)
    truth = default_bench_truth(tool)
    rows = []
    for case in CASES:
        _, loads, _ = case_recordings(seed, case, args, q_exc)
        sags = {FRICTION_SAG: friction_sag(truth), BENCH_SAG: bench_sag(tool)}
        for reading in (*READINGS, *sags):
            law = _law(truth, READINGS[-1] if reading in sags else reading)
            holds = [hold_residuals(t.frame, law, READINGS[-1], sags[reading])
                     if reading in sags else hold_residuals(t.frame, law, reading)
                     for t in loads]
            used = [h for h in holds if h is not None]
            rows.append({"seed": seed, "case": case, "reading": reading,
                         "holds": len(holds), "holds_used": len(used),
                         "rms": {c: float(np.sqrt(np.mean([h[c] ** 2 for h in used])))
                                 for c in CHANNELS},
                         "max_abs": {c: float(np.max(np.abs([h[c] for h in used])))
                                     for c in CHANNELS}})
            r = rows[-1]
            print(f"seed {seed}, {case}, {reading}: {r['holds_used']}/{r['holds']} holds, "
                  f"fz RMS {r['rms']['fz']:.3f} N (max {r['max_abs']['fz']:.3f})", flush=True)
    return rows


def main(argv=None) -> dict:
    from psmforce.experiments.report import shown_path, write_json
    from psmforce.experiments.seeds import ATI_FREE_IDENTIFICATION_SEEDS
    from psmforce.sim.dataset import SIM_VERSION
    from studies.ati_free import _excitation
    from studies.ati_free_identification import DESIGN_SEED

    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--seeds", type=int, nargs="+",
                    default=[DESIGN_SEED, *ATI_FREE_IDENTIFICATION_SEEDS])
    # the recordings of studies/ati_free_identification.py: its settings and work folder
    ap.add_argument("--scale", type=float, default=0.05)
    ap.add_argument("--free-minutes", type=float, default=1.5)
    ap.add_argument("--excitation-minutes", type=float, default=1.5)
    ap.add_argument("--excitation-seed", type=int, default=0)
    ap.add_argument("--hold-s", type=float, default=10.0)
    ap.add_argument("--work", type=Path, default=Path("runs/ati_free_identification"))
    ap.add_argument("--json", type=Path)
    args = ap.parse_args(argv)
    started = time.perf_counter()
    q_exc = _excitation(args.work, args)
    runs = [row for seed in args.seeds for row in _seed(seed, args, q_exc)]
    result = {"command": "python studies/load_path_holds.py" + (
                  f" --json {shown_path(args.json)}" if args.json else ""),
              "simulator_version": SIM_VERSION, "design_seed": DESIGN_SEED,
              "settings": {k: (shown_path(v) if isinstance(v, Path) else v)
                           for k, v in vars(args).items()},
              "readings": [*READINGS, FRICTION_SAG, BENCH_SAG], "cases": list(CASES),
              "runs": runs,
              "seconds": time.perf_counter() - started}
    if args.json:
        write_json(args.json, result)
    return result


if __name__ == "__main__":
    main()
