"""What each ``psmforce`` command does once its arguments are parsed (:mod:`psmforce.cli.main` builds
the parser): one handler per command, checking its options first (:mod:`psmforce.cli.options`)
so that a bad argument leaves nothing behind, then calling the library. Heavy modules are
imported inside the handlers, so ``psmforce --help`` stays fast.

Size: a dozen short handlers side by side, one per command; splitting them would only scatter
the one pattern (check, call, print) they share.
"""

from __future__ import annotations

import json
import sys
from pathlib import Path

from psmforce.cli import options
from psmforce.cli.guards import progress


def simulate_command(args) -> dict:
    options.scale(args.scale)
    if args.tool_spread is not None and args.tool_seed is None:
        raise ValueError("--tool-spread: only with --tool-seed (without it the bench runs the "
                         "nominal tool)")
    from psmforce.sim import simulate
    spread = 1.0 if args.tool_spread is None else args.tool_spread
    return simulate(protocol=args.protocol, scale=args.scale, seed=args.seed, out=args.out,
                    port=args.port, tool_seed=args.tool_seed, tool_spread=spread,
                    fmt=args.format, version=args.sim_version)


def excitation_command(args) -> dict:
    from psmforce.cli.excitation import FILES, check_arguments, check_out, excitation_cli
    check_out(args.out)
    options.fresh_folder(args.out, "--out")
    options.seed(args.seed, "--seed")
    from psmforce.core.files import check_name
    for name in FILES.values():
        check_name(Path(args.out) / name)
    check_arguments(args.minutes, args.seed, args.known_weights, args.paired_poses)
    with progress("excitation"):
        return excitation_cli(args.out, args.minutes, args.seed, args.known_weights,
                              args.paired_poses)


def convert_command(args) -> dict:
    from psmforce.io.bags import convert_bag, convert_csv, summary_line
    options.output_file(args.out, "--out", parents=False)
    if Path(args.bag).suffix.lower() == ".csv":
        report = convert_csv(args.bag, args.out, column_map=args.column_map)
        print(f"wrote {args.out}")
        return report
    topics = {k: v for k, v in (("js", args.topic_js), ("jaw", args.topic_jaw),
                                 ("hex10", args.topic_hex10), ("ati", args.topic_ati),
                                 ("jacobian", args.topic_jacobian)) if v is not None}
    r_ati_psm = None
    if args.r_ati_psm is not None:
        import numpy as np

        from psmforce.robot.frames import check_rotation
        option = f"--r-ati-psm {args.r_ati_psm}"
        try:  # ValueError: invalid JSON or not numbers; TypeError: null entries
            from psmforce.core.files import MAX_JSON_BYTES, read_input_text
            matrix = np.asarray(json.loads(read_input_text(args.r_ati_psm, MAX_JSON_BYTES,
                                                           "rotation")), dtype=float)
        except (OSError, ValueError, TypeError) as err:
            raise ValueError(f"{option}: not a JSON 3x3 rotation matrix ({err})") from None
        r_ati_psm = check_rotation(matrix, option)
    report = convert_bag(args.bag, args.out, rate_hz=args.rate, arm=args.arm,
                         topics=topics or None, r_ati_psm=r_ati_psm, on_gap=args.on_gap)
    print(summary_line(report))
    return report


def fit_dynamics_command(args) -> dict:
    if args.model_out:
        options.output_file(args.model_out, "--model-out")
    from psmforce.identification import fit_dynamics_cli
    print("fitting the arm's dynamics (CasADi / IPOPT; minutes on a large dataset)",
          flush=True)
    with progress("fit-dynamics"):
        report = fit_dynamics_cli(train=args.train, test=args.test, fmt=args.format,
                                  json_out=None, model_out=args.model_out, data=args.data,
                                  select=args.select, gravity=args.gravity,
                                  accept_poor_fit=args.accept_poor_fit)
    if "selection" in report:
        print(f"selected: {report['selection']['selected']} ({report['selection']['method']})")
    print(f"fit: {report['solver_status']} in {report['fit_time_s']:.1f} s, "
          f"{report['n_base_parameters']} base parameters, physically consistent "
          f"{report['physically_consistent']}; model: {report.get('model')}")
    for key in ("train_relative_error_percent", "test_relative_error_percent"):
        if key in report:
            print(f"{key.split('_')[0]} relative torque error %: " + ", ".join(
                f"{n} {e:.1f}" for n, e in zip(report["coordinates"], report[key])))
    threshold = report["poor_fit_threshold_relative_error_percent"]
    scored = report.get("test_relative_error_percent") or report.get(
        "train_relative_error_percent", [])
    above = [f"{n} {e:.0f} %" for n, e in zip(report["coordinates"], scored)
             if not e <= threshold]
    print("verdict: " + ("POOR FIT, every coordinate" if report["poor_fit"] else "passes the gate")
          + f" (relative torque error above {threshold:g} %: "
          + (", ".join(above) if above else "none") + ")"
          + ("; those coordinates' torques are not explained" if above and not report["poor_fit"]
             else ""))
    if report["poor_fit"] and not args.accept_poor_fit:
        raise ValueError(("" if args.model_out is None else f"{args.model_out} not written: ")
                         + f"poor fit: relative torque error above "
                         f"{report['poor_fit_threshold_relative_error_percent']:g} % on every "
                         f"coordinate (--accept-poor-fit keeps it)")
    return report


def wrench_command(args) -> dict:
    options.output_file(args.out, "--out", parents=False)
    from psmforce.core.files import atomic_path
    from psmforce.identification import ArmDynamicsModel
    from psmforce.identification.recordings import recording_wrench
    model = ArmDynamicsModel.load(args.dynamics)
    table = recording_wrench(model, args.recording, frame=args.frame,
                             expressed_in=args.expressed_in)
    out = Path(args.out)
    with atomic_path(out) as tmp:
        table.to_csv(tmp, index=False, float_format="%.7g")
    damped = int(table["damped"].sum())
    print(f"wrote {out}: {len(table)} samples, {damped} damped (near a singularity)")
    return {"recording": args.recording, "dynamics": args.dynamics, "out": str(out),
            "frame": args.frame, "expressed_in": args.expressed_in, "samples": len(table),
            "damped_samples": damped, "sigma_min_smallest": float(table["sigma_min"].min())}


def index_command(args) -> dict:
    from psmforce.estimators.data.dataset import index_recordings
    path = index_recordings(args.data)
    trials = json.loads(path.read_text())["trials"]
    print(f"wrote {path}: {len(trials)} recordings")
    return {"metadata": str(path), "trials": trials}


def fit_prior_command(args) -> dict:
    options.output_file(args.out, "--out")
    from psmforce.identification import fit_prior_cli
    from psmforce.io.recording import HEX10_FORCE
    print("fitting the internal-force prior (CasADi / IPOPT)", flush=True)
    with progress("fit-prior"):
        report = fit_prior_cli(args.data, args.out, use_loaded=args.use_loaded,
                               accept_poor_fit=args.accept_poor_fit, identify=args.identify,
                               inputs="load_path" if args.load_path else "efforts",
                               crosstalk=options.CROSSTALK_OPTIONS[args.crosstalk])
    metrics = report.get("test_free_metrics")
    print(f"fit: {report['solver_status']} in {report['fit_time_s']:.1f} s; test Free "
          + (", ".join(f"{c} RMS {metrics[c]['rms']:.3g}" for c in HEX10_FORCE)
             + " N" if metrics else "not scored (no test/Free recordings)"))
    from psmforce.identification.prior_report import verdict
    # identified / fixed / at a bound, then the gate and the targets
    print("verdict: " + (report.get("verdict") or verdict(report)))
    if report["model"] is None:
        raise ValueError(f"{args.out} not written: {report['model_not_saved_reason']}"
                         + (" (--accept-poor-fit saves it anyway"
                            + ("; without --identify every parameter its reading does not hold "
                               "is fitted, a curve fit" if args.identify else "") + ")"
                            if report.get("poor_fit") else ""))
    return report


def _fixed_values(items: list[str]) -> dict:
    """``--fix NAME=VALUE`` items as {name: value}, each a torque parameter and a finite
    number inside its bounds."""
    import math

    from psmforce.identification.transmission.model import TORQUE_PARAMETERS
    bounds = {p[0]: (p[2], p[3]) for p in TORQUE_PARAMETERS}
    out = {}
    for item in items:
        name, sep, text = item.partition("=")
        if not sep or name not in bounds:
            raise ValueError(f"--fix: expected NAME=VALUE with NAME one of {list(bounds)}, got "
                             f"{item!r}")
        try:
            value = float(text)
        except ValueError:
            raise ValueError(f"--fix {name}: {text!r} is not a number") from None
        lo, hi = bounds[name]
        if not (math.isfinite(value) and lo <= value <= hi):
            raise ValueError(f"--fix {name}: {value} is outside its bounds [{lo:g}, {hi:g}]")
        out[name] = value
    return out


def fit_transmission_command(args) -> dict:
    options.output_file(args.out, "--out")
    import math
    import warnings

    from psmforce.identification.transmission import roles
    from psmforce.identification.transmission.model import CableTransmission
    from psmforce.identification.transmission.recording import (TransmissionDataWarning,
                                                                home_session,
                                                                read_transmission_session)
    fixed = _fixed_values(args.fix)
    if args.bootstrap < 0:
        raise ValueError(f"--bootstrap must be 0 or more, got {args.bootstrap}")
    base = CableTransmission.load(args.recalibrate) if args.recalibrate else None
    if base is not None and (fixed or args.bootstrap or args.validation):
        raise ValueError("--recalibrate fits only the per-session parameters: --fix, "
                         "--bootstrap and --validation do not apply")
    if len(set(args.session)) != len(args.session):
        raise ValueError("a session folder is given twice")
    recordings = []
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always", TransmissionDataWarning)
        for folder in args.session:
            recordings += home_session(read_transmission_session(
                folder, args.rate_hz, keep_flagged=args.keep_flagged))
    left_out = [str(w.message) for w in caught if w.category is TransmissionDataWarning]
    for line in left_out:
        print(f"note: {line} (--keep-flagged fits on them)")
    by_name = {r.name: r for r in recordings}
    validation = []
    for name in args.validation:
        hits = [r for full, r in by_name.items()
                if full == name or (len(args.session) == 1 and full.rsplit("/", 1)[1] == name)]
        if not hits:
            raise ValueError(f"--validation: no file {name}.TXT in {', '.join(args.session)}")
        validation += hits
    fit_on = [r for r in recordings if r not in validation]
    if not fit_on:
        raise ValueError("--validation holds every file: nothing left to fit on")
    report_roles = None
    with progress("fit-transmission"):
        if base is not None:
            model = base.recalibrate(fit_on)
        elif args.bootstrap:
            model, report_roles = roles.identify(fit_on, validation=validation,
                                                 resamples=args.bootstrap,
                                                 current_source=args.current_source,
                                                 declared_fixed=fixed)
        else:
            model = CableTransmission.fit(fit_on, validation=validation, fixed=fixed,
                                          current_source=args.current_source)
    model.save(args.out)
    report = {"model": args.out, "fit_files": [r.name for r in fit_on], "left_out": left_out,
              "validation_files": [r.name for r in validation], **model.to_dict(),
              "roles": report_roles["roles"] if report_roles else roles.roles_table(model),
              "bootstrap": report_roles["bootstrap"] if report_roles else None,
              "fit_scores": model.score(fit_on),
              "validation_scores": model.score(validation) if validation else None}
    if base is not None:
        fresh = {s: v for s, v in model.sessions.items() if s not in base.sessions}
        print(f"recalibrated {sorted(fresh) or sorted(model.sessions)} on {len(fit_on)} files; "
              "constants kept from " + args.recalibrate)
    else:
        ident = model.info["identifiability"]
        print(f"fit: {model.info['solver_status']} in {model.info['fit_time_s']:.1f} s on "
              f"{len(fit_on)} files of {len({r.session for r in fit_on})} session(s); Fisher "
              f"condition number {ident['fisher_condition_number']:.3g} (white noise: a "
              "diagnostic)" + (f"; {model.info['tied']}" if model.info.get("tied") else ""))
        if report_roles:
            print(f"identifiability (bootstrap over files, {args.bootstrap} resamples): "
                  + (f"fixed at design values: {', '.join(report_roles['not_identifiable'])}"
                     if report_roles["not_identifiable"] else "every shared parameter pinned"))
        else:
            print("identifiability: not measured (--bootstrap N measures it)")
        bound = sorted(set(ident["at_bound"]))
        print("at a bound: " + (", ".join(bound) if bound else "none"))
    for label in ("fit", "validation"):
        score = report[f"{label}_scores"]
        if score:
            print(f"{label}: jaw torque RMSE {1e3 * score['jaw_torque_rmse_nm']:.2f} mNm, jaw "
                  f"angle RMSE {math.degrees(score['jaw_angle_rmse_rad']):.2f} deg")
    # its one gate is convergence (a fit that does not converge raises and writes nothing)
    print(f"verdict: converged ({model.info['solver_status']}), the only gate of this fit; "
          + ("judge it by the validation RMSE above" if validation else
             "no held-out files (--validation), so scored on its own fit data only"))
    print(f"wrote {args.out}")
    return report


def _models(names, option: str) -> None:
    """Every name a model of the recipe table, none twice."""
    from psmforce.estimators.networks.recipes import RECIPES
    for k, name in enumerate(names):
        if name not in RECIPES:
            raise ValueError(f"{option}: unknown model '{name}'; known: {list(RECIPES)}")
        if name in names[:k]:
            raise ValueError(f"{option}: '{name}' given more than once")


def train_command(args) -> dict:
    options.training_options(args)
    _models([args.model], "--model")
    config = options.json_object(args.config, "--config")
    from psmforce.estimators.training.train import train  # checks the config before the data
    return train(args.data, args.model, args.out, features=args.features, epochs=args.epochs,
                 seed=args.seed, device=args.device, prior=args.prior, config=config,
                 prior_crosstalk=args.prior_crosstalk)


def finetune_command(args) -> dict:
    options.training_options(args)
    from psmforce.estimators.training.train import finetune
    return finetune(args.checkpoint, args.data, args.out, epochs=args.epochs, seed=args.seed,
                    device=args.device)


def calibrate_command(args) -> dict:
    options.training_options(args)
    if args.known_loads is not None and not args.free_space:
        raise ValueError("--known-loads: only with --free-space (a calibration with the ATI "
                         "measures its loads)")
    if args.prior_refit != "all" and not args.free_space:
        raise ValueError(f"--prior-refit {args.prior_refit}: only with --free-space (a "
                         f"calibration with the ATI refits the prior on its own loads)")
    for flag, value, default in (("--held-values", args.held_values, "as-held"),
                                 ("--jackknife-unit", args.jackknife_unit, "orientation"),
                                 ("--hold-rule", args.hold_rule, "imprecise"),
                                 ("--clenched-lateral", args.clenched_lateral, False),
                                 ("--free-lateral-offsets", args.free_lateral_offsets, False)):
        if value != default and args.known_loads is None and args.prior_refit != "identified":
            raise ValueError(f"{flag}: only with --known-loads or --prior-refit identified (the "
                             f"instrument's identification through the load path)")
    network_off = options.network_off(args.network_off)
    if network_off == "carried" and args.prior_refit != "identified":
        raise ValueError("--network-off carried: only with --prior-refit identified (the axes "
                         "whose cross-talk the identification carried into the prior)")
    if args.known_loads is not None and not Path(args.known_loads).is_dir():
        raise ValueError(f"--known-loads: {args.known_loads} is not a dataset folder")
    from psmforce.estimators.training.calibrate import calibrate
    result = calibrate(args.checkpoint, args.data, args.out, minutes=args.minutes,
                       epochs=args.epochs, seed=args.seed, device=args.device,
                       free_space=args.free_space, known_loads=args.known_loads,
                       held_values=args.held_values, jackknife_unit=args.jackknife_unit,
                       prior_refit=args.prior_refit, hold_rule=args.hold_rule,
                       network_off=network_off, finetune=not args.no_finetune,
                       network_prior=args.network_prior,
                       clenched_lateral=args.clenched_lateral,
                       free_lateral_offsets=args.free_lateral_offsets)
    record = result["calibration"]
    print(f"calibrated on {len(record['trials'])} trials, {record['minutes_used']:.2f} min "
          f"(Free {record['minutes_by_condition']['Free']:.2f}, Traction "
          f"{record['minutes_by_condition']['Traction']:.2f}"
          + (f", KnownLoad {record['minutes_by_condition']['KnownLoad']:.2f}"
             if record["known_loads_dir"] else "") + ")"
          + (", prior refitted" if record["prior_refit"] else "")
          + (f"; {record['epochs_run']} epochs ({record['stopped_by']})" if record.get(
              "finetuned", True) else "; the network kept as trained (not finetuned)")
          + f"; wrote {args.out}")
    held = (record["prior_refit"] or {}).get("held_from_checkpoint")
    if held:  # without an ATI: what these recordings could not pin down (docs/ati_free.md)
        print(f"not identifiable from these recordings, held at the checkpoint's values: "
              f"{', '.join(sorted(held))}")
    if record.get("instrument_identification"):  # with known loads, through the load path
        print(f"instrument (load path): {record['instrument_identification']['verdict']}")
    carried = (record["prior_refit"] or {}).get("held_at_identified")
    if carried:
        print(f"held in the prior at the instrument's identified values: "
              f"{', '.join(sorted(carried))}")
    if network_off != "none":
        axes = record["physics_only_axes"]["axes"]
        print("the prior alone answers " + (", ".join(axes) if axes else "no axis")
              + (" (the identification carried no lateral cross-talk)"
                 if not axes and network_off == "carried" else "")
              + ("; the network reads the prior it was trained with"
                 if args.network_prior == "trained" else ""))
    return result


def evaluate_command(args) -> dict:
    options.fresh_folder(args.out, "--out")
    from psmforce.estimators.training.checkpoint import load_checkpoint, trial_hashes
    from psmforce.estimators.data.sanity import repeated_recordings
    from psmforce.estimators.evaluation.evaluate import causal_table, evaluate
    known = trial_hashes(load_checkpoint(args.checkpoint).provenance)
    repeats = repeated_recordings(args.data, "test", known)
    if repeats and not args.allow_train_overlap:
        rel, match = repeats[0]
        raise ValueError(f"{Path(args.data) / rel}: same content as {match}, a trial "
                         f"{args.checkpoint} was trained on"
                         + (f" ({len(repeats)} test recordings repeat training ones)"
                            if len(repeats) > 1 else "")
                         + ": its scores would be leaked (--allow-train-overlap scores anyway)")
    for rel, match in repeats:
        print(f"psmforce evaluate: warning: test recording {rel} has the content of training "
              f"trial {match}: its scores are not held-out", file=sys.stderr)
    result = evaluate(args.checkpoint, args.data, args.out)
    if repeats and isinstance(result, dict):
        result["train_overlap"] = [{"test": rel, "train": match} for rel, match in repeats]
    # the console's headline is what a haptic loop gets; every metric is in OUT/metrics.md
    print(causal_table(result) + f"\nAll metrics (paper's, by condition): "
          f"{Path(args.out) / 'metrics.md'}", flush=True)
    return result


def reproduce_command(args) -> dict:
    # before reproduce() writes OUT/work: bad arguments leave nothing behind
    options.scale(args.scale)
    for seed in args.seeds:
        options.seed(seed, "--seeds")
    repeated = sorted({s for s in args.seeds if args.seeds.count(s) > 1})
    if repeated:
        raise ValueError(f"--seeds: {repeated[0]} given more than once; each seed is one "
                         f"independent run, a repeat would report a spread of 0")
    if args.models is not None:
        _models(args.models, "--models")
    if args.finish_on:
        options.device(args.finish_on, "--finish-on")
    else:
        options.device(args.device)
    target = Path(args.out)
    if target.exists() and not target.is_dir():
        raise ValueError(f"--out: {target} exists and is not a folder")
    options.writable_ancestor(target, "--out")
    from psmforce.experiments.reproduce import reproduce
    return reproduce(args.out, scale=args.scale, seeds=args.seeds, device=args.device,
                     finish_on=args.finish_on, budget=args.budget, models=args.models,
                     ablations=not args.no_ablations, efficiency=not args.no_efficiency,
                     teleop=not args.no_teleop, port=args.port, ray_address=args.ray)


def export_command(args) -> dict:
    options.fresh_folder(args.out, "--out")
    from psmforce.estimators.runtime.export import export
    return export(args.checkpoint, args.out)


def upgrade_checkpoint_command(args) -> dict:
    options.output_file(args.out, "--out")
    from psmforce.estimators.training.checkpoint import upgrade_checkpoint
    result = upgrade_checkpoint(args.checkpoint, args.out)
    print(f"sealed {args.checkpoint} as format 3: {args.out}"
          + ("" if result["trial_sha256"] else " (it names no trial hashes: evaluate cannot "
                                                "check its test sets against its training)"))
    return result


def demo_command(args) -> dict:
    from psmforce.cli.demo import run_demo
    return run_demo(args.out, seed=args.seed)
