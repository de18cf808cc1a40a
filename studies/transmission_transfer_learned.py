"""The learned models and the hybrid on the transfer protocols of
``studies/transmission_transfer.py``: trained on ``Tool_4_Maryland_L_4``, scored on every other
folder as is and after its 60 s calibration.

    python studies/transmission_transfer_learned.py --seeds 1 --jobs 2 \\
        --json results/benchmarks/transmission_transfer_learned.json      # resumable

Inputs (every model): the signals a robot has, causal at 100 Hz: motor current, the drive's
command, motor angle and velocity; outputs jaw torque and angle, standard-scaled with the
training statistics (:mod:`psmforce.experiments.transmission_networks`). Models: FCN, LSTM, the
paper's transformer, MultiRocket-Hydra, and the hybrid: the physics of the transfer study (its
roles, widths and fixed values read from ``transmission_transfer.json``, refitted on the same
training files) plus the paper's transformer on its residual, the physics' two outputs among its
inputs. Training: ``Tool_4_Maryland_L_4``'s training files, early-stopped on its validation files
(the split of ``studies/transmission.py``), at most 150 epochs.

Per folder, on the files outside its calibration (the transfer study's ``calibration_files``):

* ``as_is``: the trained model (the hybrid with the physics' L_4 values);
* ``recalibrated``: every model finetuned the same way on the calibration files (all weights,
  learning rate 1e-4, the first 80 % of each file to train, the last 20 % to stop early, at most
  :data:`FINETUNE_EPOCHS` epochs and :data:`FINETUNE_LIMIT_S` s; MultiRocket refits its ridge
  head); the hybrid's physics is recalibrated first (its per-session parameters), then its
  network finetuned on the new residual;
* ``hybrid, physics recalibrated only``: the hybrid's network as is on the recalibrated physics
  (the cheap procedure: no training at the robot);
* ``hybrid, residual kept where it helps``: the recalibrated hybrid, or the recalibrated physics
  alone where the finetune's validation data say the network does not help (:data:`SELECTION`).
  Every finetune already keeps its starting weights when no epoch improves on that data; a zero
  residual is the one further choice only the hybrid has.

Metrics as in the transfer study (torque mNm, angle deg, whole and closing). One seed gives no
spread: with one seed a difference is reported, never a win by the spread rule.

Only the hybrid reads the physics, so when the physics changes (``transmission_transfer.json``
regenerated) only the hybrid needs training again::

    python studies/transmission_transfer_learned.py --seeds 1 --models hybrid \
        --reuse results/benchmarks/transmission_transfer_learned.json \
        --json results/benchmarks/transmission_transfer_learned.json

``--reuse`` copies the records of every model not in ``--models`` from an earlier JSON of this
study, refused unless its inputs, seeds and finetuning settings are this run's.
"""

from __future__ import annotations

import argparse
import copy
import json
import sys
import time
import warnings
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from psmforce.core.files import atomic_path, write_json_atomic  # noqa: E402
from psmforce.experiments.report import shown_path  # noqa: E402
from psmforce.estimators.evaluation.tables import std_over_seeds  # noqa: E402

MODELS = ("fcn", "lstm", "transformer", "rocket", "hybrid")
INPUTS = ("motor_current_a", "motor_command", "motor_angle_rad", "motor_velocity_rad_s")
FINETUNE_EPOCHS = 1000
FINETUNE_LIMIT_S = 180.0
CALIBRATION_VAL_FRACTION = 0.2
FINETUNE_VALIDATION = {
    "tail": "the last 20 % of each calibration file (the first 80 % trains)",
    "file": "the middle load's calibration file, whole (the other two train)",
}
"""What a finetune stops early on (``--finetune-validation``). ``tail`` is the first protocol;
``file`` was added after the roll folders' rows showed every finetuned model far behind the
recalibrated physics there, since a file's own tail cannot tell a fit to that file from one that
holds on another grasp (every model gets the same)."""
TRANSFER_JSON = ROOT / "results" / "benchmarks" / "transmission_transfer.json"


def _data(data_dir: Path):
    from psmforce.identification.transmission.recording import TransmissionDataWarning
    from studies.transmission_transfer import _source_split, load
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", TransmissionDataWarning)
        data, _ = load(data_dir, False)
    return data, _source_split(data, False)


def _physics(train: list, transfer: dict):
    """The transfer study's physics: its widths, fixed values and current source, refitted on
    the same training files (deterministic)."""
    from psmforce.identification.transmission.model import CableTransmission
    m = transfer["model"]
    fixed = {n: m["torque"][n]["value"] for n in m["fixed"]}
    widths = CableTransmission(presliding_rad=m["presliding_rad"], hold_rad=m["hold_rad"],
                               backlash_rad=m["backlash_rad"])
    return CableTransmission.fit(train, initial=widths, fixed=fixed,
                                 per_session=tuple(m["per_session"]),
                                 current_source=m["current_source"])


def run_model(model: str, seed: int, data_dir: str, work: str,
              validation: str = "tail") -> list[dict]:
    """Train ``model`` on L_4, score it on every folder as is and recalibrated (the finetune
    early-stopped on :data:`FINETUNE_VALIDATION` ``validation``); every record kept under
    ``work`` and reused."""
    import torch

    from psmforce.experiments import transmission_networks as tm
    from studies.transmission_transfer import _closing_rmse, calibration_files
    torch.set_num_threads(1)
    work = Path(work)
    data, (train, val, test) = _data(Path(data_dir))
    transfer = json.loads(TRANSFER_JSON.read_text())
    physics = _physics(train, transfer) if model == "hybrid" else None

    class Prediction:
        def __init__(self, torque, angle):
            self.jaw_torque_nm, self.jaw_angle_rad = torque, angle

    def arrays(rec, phys):
        x = np.stack([getattr(rec, k) for k in INPUTS], 1)
        y = np.stack([getattr(rec, k) for k in tm.TARGETS], 1)
        if phys is None:
            return x, y, None
        p = phys.predict(rec)
        base = np.stack([p.jaw_torque_nm, p.jaw_angle_rad], 1)
        return np.concatenate([x, base], 1), y - base, base

    train_xy = [arrays(r, physics) for r in train]
    xs, ys = tm.Scaler.fit([a[0] for a in train_xy]), tm.Scaler.fit([a[1] for a in train_xy])

    def series(rec, phys, lo=0, hi=None, mask_from=None):
        x, y, _ = arrays(rec, phys)
        mask = None if mask_from is None else np.arange(len(x)) >= mask_from
        return tm.Series.of(xs(x)[lo:hi], ys(y)[lo:hi], None if mask is None else mask[lo:hi])

    if model == "rocket":
        est, settings = tm.RocketModel(seed), tm.RocketModel.settings
    else:
        torch.manual_seed(seed)
        net, settings = tm.build_network("transformer" if model == "hybrid" else model,
                                         len(INPUTS) + (2 if physics else 0))

    class Scored:
        """What _closing_rmse needs: ``predict(rec)`` with the estimator's current weights."""

        def __init__(self, phys):
            self.phys = phys

        def predict(self, rec):
            x, _, base = arrays(rec, self.phys)
            s = est.predict_scaled(xs(x)) if model == "rocket" else tm.predict_scaled(
                net, settings, xs(x))
            out = ys.invert(s) + (0.0 if base is None else base)
            return Prediction(out[:, 0], out[:, 1])

    def kept(name, compute):
        path = work / "records" / f"{model}_seed{seed}_{name}.json"
        if path.exists():
            return json.loads(path.read_text())
        value = compute()
        path.parent.mkdir(parents=True, exist_ok=True)
        write_json_atomic(path, value)
        return value

    weights = work / "models" / f"{model}_seed{seed}.pt"
    if weights.exists():
        state = torch.load(weights, weights_only=False)
        (est.reg if model == "rocket" else net).load_state_dict(state["weights"])
        report = state["report"]
    else:
        tr, va = [series(r, physics) for r in train], [series(r, physics) for r in val]
        report = (est.fit(tr, va) if model == "rocket" else
                  tm.train(net, settings, tr, va, seed=seed, max_epochs=150, time_limit_s=2400))
        weights.parent.mkdir(parents=True, exist_ok=True)
        with atomic_path(weights) as tmp:  # a killed run never leaves a partial file to resume
            torch.save({"weights": (est.reg if model == "rocket" else net).state_dict(),
                        "report": report}, tmp)
    trained = copy.deepcopy((est.reg if model == "rocket" else net).state_dict())
    records = [kept("in_session", lambda: {"model": model, "seed": seed, "folder":
                                           "Tool_4_Maryland_L_4", "protocol": "in_session",
                                           "metrics": _closing_rmse(Scored(physics), test),
                                           "fit": report})]
    for folder, recs in data.items():
        if folder == "Tool_4_Maryland_L_4":
            continue
        calib = calibration_files(recs)
        scored = [r for r in recs if r not in calib]
        records.append(kept(f"{folder}_as_is", lambda: {
            "model": model, "seed": seed, "folder": folder, "protocol": "as_is",
            "metrics": _closing_rmse(Scored(physics), scored)}))
        phys_cal = physics.recalibrate(calib) if physics else None
        if physics:
            records.append(kept(f"{folder}_physics_only", lambda: {
                "model": "hybrid_physics_recalibrated_only", "seed": seed, "folder": folder,
                "protocol": "recalibrated",
                "metrics": _closing_rmse(Scored(phys_cal), scored)}))

        def calibration_split():
            cal_train, cal_val = [], []
            for k, rec in enumerate(calib):
                if validation == "file":  # the middle load's file held out whole
                    (cal_val if k == 1 else cal_train).append(series(rec, phys_cal))
                    continue
                cut = round(len(rec) * (1 - CALIBRATION_VAL_FRACTION))
                cal_train.append(series(rec, phys_cal, 0, cut))
                cal_val.append(series(rec, phys_cal, mask_from=cut))
            return cal_train, cal_val

        def finetuned():
            cal_train, cal_val = calibration_split()
            if model == "rocket":
                fit = est.fit(cal_train, cal_val, refit=True)
            else:
                fit = tm.train(net, settings, cal_train, cal_val, seed=seed, lr=1e-4,
                               max_epochs=FINETUNE_EPOCHS, time_limit_s=FINETUNE_LIMIT_S)
            out = {"model": model, "seed": seed, "folder": folder, "protocol": "recalibrated",
                   "metrics": _closing_rmse(Scored(phys_cal), scored), "fit": fit}
            (est.reg if model == "rocket" else net).load_state_dict(copy.deepcopy(trained))
            return out

        records.append(kept(f"{folder}_recalibrated", finetuned))
        if physics:
            def physics_val_loss():  # _val_loss's definition, for a zero residual
                zero = ys(np.zeros((1, 2)))
                return float(np.concatenate(
                    [((zero - s.y) ** 2)[s.mask] for s in calibration_split()[1]]).mean())

            records.append(kept(f"{folder}_selected", lambda: selected(
                records[-1], _closing_rmse(phys_cal, scored), physics_val_loss())))
    return records


SELECTION = ("the hybrid's recalibration keeps its residual network only where it helps: on the "
             "data its finetune stops early on, the finetuned network's "
             "best loss against the physics alone's (a zero residual), the lower kept")
"""``hybrid_selected``, added after the L_2 and Tool_5 rows showed the recalibrated physics alone
ahead of the hybrid. The finetuned network's loss is the minimum over the epochs on that data
(its early stopping's), so the choice leans towards keeping the network."""


def selected(finetuned: dict, physics_alone: dict, physics_val_loss: float) -> dict:
    """The ``hybrid_selected`` record of one folder: the finetuned hybrid's metrics or the
    recalibrated physics alone's (``physics_alone``), whichever scored the lower loss on the
    finetune's validation data (:data:`SELECTION`); which was kept and both losses are
    recorded."""
    network_loss = float(finetuned["fit"]["best_val_loss"])
    keep = network_loss <= physics_val_loss
    return {"model": "hybrid_selected", "seed": finetuned["seed"], "folder": finetuned["folder"],
            "protocol": "recalibrated",
            "metrics": finetuned["metrics"] if keep else physics_alone,
            "selection": {"kept": "residual network" if keep else "physics alone",
                          "network_val_loss": network_loss,
                          "physics_alone_val_loss": physics_val_loss}}


def summarise(records: list[dict]) -> dict:
    """{folder: {protocol: {model: {part: {metric: {mean, std, seeds}}}}}}: std the sample
    standard deviation over the seeds (ddof 1; None for one seed,
    :func:`psmforce.estimators.evaluation.tables.std_over_seeds`), ``seeds`` how many."""
    out: dict = {}
    for r in records:
        slot = out.setdefault(r["folder"], {}).setdefault(r["protocol"], {}).setdefault(
            r["model"], {})
        for part, m in r["metrics"].items():
            for k in ("torque_rmse_mNm", "angle_rmse_deg"):
                slot.setdefault(part, {}).setdefault(k, []).append(m[k])
    for folder in out.values():
        for protocol in folder.values():
            for model in protocol.values():
                for part in model.values():
                    for k, v in part.items():
                        part[k] = {"mean": float(np.mean(v)), "std": std_over_seeds(v),
                                   "seeds": len(v)}
    return out


def reused_records(path: Path, models: list[str], seeds: list[int],
                   validation: str = "tail") -> tuple[list[dict], list]:
    """The records of the models not in ``models`` from an earlier JSON of this study, and which
    models they are. Refused (ValueError naming the difference) unless that run's inputs, seeds
    and finetuning settings are this run's, or when it lacks a model it should give."""
    try:
        old = json.loads(Path(path).read_text())
    except (OSError, ValueError) as exc:
        raise ValueError(f"--reuse {path}: not a readable JSON ({exc})") from None
    if not isinstance(old, dict) or not isinstance(old.get("records"), list):
        raise ValueError(f"--reuse {path}: not a JSON of this study (no 'records' list)")
    mine = {"inputs": list(INPUTS), "seeds": seeds, "finetune": _finetune_settings(validation)}
    if isinstance(old.get("finetune"), dict):  # written before the option: the tail
        old["finetune"] = {"validation": "tail", **old["finetune"]}
    for key, value in mine.items():
        if old.get(key) != value:
            raise ValueError(f"--reuse {path}: its {key} {old.get(key)!r} differ from this "
                             f"run's {value!r}")
    taken = [m for m in old.get("models", []) if m not in models]
    missing = [m for m in MODELS if m not in models and m not in taken]
    if missing:
        raise ValueError(f"--reuse {path}: it has no records of {', '.join(missing)}")
    wanted = set(taken) | ({"hybrid_physics_recalibrated_only", "hybrid_selected"}
                           if "hybrid" in taken else set())
    records = [r for r in old["records"] if r.get("model") in wanted]
    return records, taken


def _finetune_settings(validation: str = "tail") -> dict:
    return {"epochs": FINETUNE_EPOCHS, "time_limit_s": FINETUNE_LIMIT_S, "lr": 1e-4,
            "validation_fraction": CALIBRATION_VAL_FRACTION, "validation": validation}


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--data", type=Path, default=ROOT.parent / "shared" / "data" / "mrdlab")
    ap.add_argument("--json", type=Path, required=True)
    ap.add_argument("--work", type=Path, default=ROOT / "runs" / "transmission_transfer")
    ap.add_argument("--seeds", type=int, nargs="+", default=[1])
    ap.add_argument("--models", nargs="+", choices=MODELS, default=list(MODELS))
    ap.add_argument("--jobs", type=int, default=1)
    ap.add_argument("--finetune-validation", choices=list(FINETUNE_VALIDATION),
                    default="tail", help="what a finetune stops early on")
    ap.add_argument("--reuse", type=Path, default=None,
                    help="an earlier JSON of this study: the records of the models not in "
                         "--models are taken from it")
    args = ap.parse_args(argv)
    t0 = time.perf_counter()
    reused, models = [], list(args.models)
    if args.reuse is not None:
        try:
            reused, taken = reused_records(args.reuse, models, args.seeds,
                                           args.finetune_validation)
        except ValueError as exc:
            print(f"error: {exc}", file=sys.stderr)
            return 2
        models = [m for m in MODELS if m in models or m in taken]
    jobs = [(m, s) for s in args.seeds for m in args.models]
    with ProcessPoolExecutor(max_workers=args.jobs) as pool:
        done = list(pool.map(run_model, *zip(*jobs), [str(args.data)] * len(jobs),
                             [str(args.work)] * len(jobs),
                             [args.finetune_validation] * len(jobs)))
    records = reused + [r for rs in done for r in rs]
    transfer = json.loads(TRANSFER_JSON.read_text())
    summary = summarise(records)
    for folder, f in transfer["folders"].items():  # the physics rows, from the transfer study
        slot = summary.setdefault(folder, {})
        for protocol in ("as_is", "recalibrated", "in_session"):
            if protocol in f:
                slot.setdefault(protocol, {})["physics"] = {
                    part: {k: {"mean": f[protocol][part][k], "std": 0.0, "seeds": 0}
                           for k in ("torque_rmse_mNm", "angle_rmse_deg")}
                    for part in ("whole", "closing")}
    result = {"benchmark": "transmission transfer, learned models and the hybrid",
              "command": "python studies/transmission_transfer_learned.py --seeds "
                         + " ".join(map(str, args.seeds))
                         + (" --models " + " ".join(args.models) + " --reuse "
                            + shown_path(args.reuse) if args.reuse is not None else "")
                         + (f" --finetune-validation {args.finetune_validation}"
                            if args.finetune_validation != "tail" else "")
                         + (" --work " + shown_path(args.work)
                            if args.work != ap.get_default("work") else "")
                         + " --json " + shown_path(args.json),
              "inputs": list(INPUTS), "seeds": args.seeds, "models": models,
              "reused": ({"from": shown_path(args.reuse),
                          "models": [m for m in models if m not in args.models]}
                         if args.reuse is not None else None),
              "finetune": _finetune_settings(args.finetune_validation),
              "selection": SELECTION if "hybrid" in models else None,
              "summary": summary, "records": records,
              "run": {"seconds": round(time.perf_counter() - t0, 1)}}
    write_json_atomic(args.json, result)
    print(f"wrote {shown_path(args.json)}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
