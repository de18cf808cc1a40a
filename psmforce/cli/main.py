"""`psmforce`: the command line over the library.

Every subcommand explains its inputs and outputs in ``--help``, exits 0 on success, and on
failure prints one line ``psmforce <command>: error: <reason>`` to stderr and exits 2, leaving
no partial output files (each library call writes atomically or into a fresh folder).
Where a command produces figures, ``--json PATH`` writes them machine-readably (``--json -``: on
standard output; a path that exists and is not a regular file is refused).

One error boundary (:func:`main`): a refused input (the library's errors, all ValueError,
OSError, RuntimeError or KeyError) exits 2; any other exception is a bug and still ends in one
line, ``psmforce <command>: internal error: <type>: <reason>``, exit 3; ``psmforce --debug
<command> ...`` prints the traceback as well. Ctrl-C exits 130. Before any work, no output may
be one of the command's inputs or a file inside an input folder, and no two outputs may be the
same file (:func:`psmforce.cli.guards.outputs_spare_inputs`).

Size: one parser for every command, each command's options beside its help, so that ``--help``
and the code agree; the commands' work is in :mod:`.offline`, :mod:`.live` and :mod:`.remount`.
"""

from __future__ import annotations

import argparse
import sys
import traceback

from psmforce import __version__
from psmforce.cli import guards, offline, options, remount


def training_arguments(p: argparse.ArgumentParser, report: str) -> None:
    """The options every training command shares (train, finetune, calibrate)."""
    p.add_argument("--epochs", type=int, default=100, help="epoch limit (default 100); early "
                   "stopping on validation ends training first when it fires")
    p.add_argument("--seed", type=int, default=0, help="validation split, initialisation and "
                   "shuffling (default 0)")
    p.add_argument("--device", default="cpu", choices=["cpu", "cuda"])
    p.add_argument("--json", help=f"write {report} here")


def _parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="psmforce",
        description="Tool-tip force estimation for the dVRK PSM with a shaft-integrated HEX10 sensor.")
    parser.add_argument("--version", action="version", version=f"psmforce {__version__}")
    parser.add_argument("--debug", action="store_true",
                        help="on failure, print the traceback as well as the one-line reason")
    parser.add_argument("--plugin", action="append", default=[], metavar="MODULE",
                        help="import MODULE first: it registers a model of your own "
                             "(psmforce.estimators.networks.recipes.register), which a checkpoint "
                             "names but never imports itself; repeatable")
    sub = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")

    def add(name, func, help_, description):
        p = sub.add_parser(name, help=help_, description=description)
        p.set_defaults(func=func)
        p.add_argument("--debug", action="store_true", default=argparse.SUPPRESS,
                       help="on failure, print the traceback as well as the one-line reason")
        return p

    p = add("simulate", offline.simulate_command, "generate a simulated bench dataset",
            "Simulate the benchtop (PSM + modified Cadiere forceps + HEX10 + ATI Nano17) running "
            "the paper's protocols. Writes OUT/metadata.json and one CSV per trial "
            "(OUT/{train,test}/{Free,Traction,Palpation}/ or OUT/config_k/{Rigid,Soft,Free}/); "
            "with --format mcap one ROS 2 bag per trial instead, as a real bench records them.")
    p.add_argument("--protocol", choices=["automated", "teleop"], default="automated")
    p.add_argument("--scale", type=float, default=1.0,
                   help="fraction of the paper's protocol to run (1.0 = about 200 min of data)")
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--port", choices=["none", "cannula", "abdominal-wall"], default="none",
                   help="the cannula the shaft passes through at the remote centre: seal friction "
                        "and lateral port forces the joints feel and the HEX10 does not (default "
                        "none: the paper's benchtop); recorded in metadata.json")
    p.add_argument("--tool-seed", type=int, metavar="N",
                   help="another modified tool: instrument parameters drawn with "
                        "InstrumentParams.sample(N, --tool-spread) (default: the nominal tool); "
                        "seed and spread recorded in metadata.json under 'tool'")
    p.add_argument("--tool-spread", type=float, metavar="S",
                   help="with --tool-seed: the draw's spread, 1 = the nominal tool-to-tool "
                        "spread of docs/simulator.md section 10, 2 = twice it (default 1)")
    p.add_argument("--sim-version", default=None, metavar="V",
                   help="simulator version: 2.1 (default), 2.2, 2.3 (docs/simulator.md)")
    p.add_argument("--format", choices=["csv", "mcap"], default="csv",
                   help="csv (default): one recording CSV per trial; mcap: one ROS 2 MCAP bag "
                        "folder per trial on the dVRK CRTK topics (/PSM1/measured_js, "
                        "/PSM1/jaw/measured_js, /hex10/measured_cf, /ati/measured_cf), plus "
                        "OUT/R_ati_psm.json for convert --r-ati-psm (docs/own_robot.md)")
    p.add_argument("--out", required=True, help="output folder (must not hold a dataset yet)")
    p.add_argument("--json", help="write the run summary here")

    p = add("convert", offline.convert_command, "convert a ROS bag to the recording CSV layout",
            "Read a ROS 2 (sqlite3 or MCAP) or ROS 1 bag with the dVRK CRTK topics, resample all "
            "streams onto one clock and write one recording CSV; reports gaps, duplicates and "
            "out-of-order messages. A .csv input with --column-map is renamed to our layout.")
    p.add_argument("bag", help="bag file, ROS 2 bag folder, or a CSV export")
    p.add_argument("--out", required=True, help="CSV file to write")
    p.add_argument("--rate", type=options.RATE_HZ, default=100.0,
                   help="output rate in Hz (default 100; at most 10 kHz)")
    p.add_argument("--arm", default="PSM1", type=options.ros_name(namespace=True), help="arm namespace (default PSM1)")
    p.add_argument("--topic-js", type=options.ros_name(), help="arm JointState topic (default /ARM/measured_js)")
    p.add_argument("--topic-jaw", type=options.ros_name(), help="jaw JointState topic (default /ARM/jaw/measured_js)")
    p.add_argument("--topic-hex10", type=options.ros_name(), help="HEX10 WrenchStamped topic (default /hex10/measured_cf)")
    p.add_argument("--topic-ati", type=options.ros_name(), help="ATI WrenchStamped topic (default /ati/measured_cf)")
    p.add_argument("--topic-jacobian", help="spatial Jacobian topic (optional)")
    p.add_argument("--r-ati-psm", help="JSON file with the 3x3 rotation R_ati_PSM (fixture "
                   "calibration); with it the ATI targets ati_fx..fz are written (paper eq. 4)")
    p.add_argument("--on-gap", choices=["drop", "flag"], default="drop",
                   help="rows inside a stream gap: drop them (default) or keep with in_gap=1")
    p.add_argument("--column-map", help="for a CSV export: JSON mapping its column names to ours")
    p.add_argument("--json", help="write the conversion report here")

    p = add("fit-dynamics", offline.fit_dynamics_command, "identify the arm's dynamics (CasADi)",
            "Fit physically consistent arm dynamics plus friction (CasADi / IPOPT) on free-space "
            "training recordings and report per-coordinate relative torque errors on the "
            "training and test recordings. Our layout (default): any rate, cut at time gaps; "
            "from a dataset folder only its Free recordings. docs/identification.md.")
    p.add_argument("--format", choices=["csv", "wpi"], default="csv",
                   help="'csv' (default): recordings in our layout (--data); 'wpi': the WPI "
                        "dvrk_dynamics_identification files (--train, --test)")
    p.add_argument("--data", metavar="DIR|FILE",
                   help="csv: a dataset folder (its train split fits, its test split scores), a "
                        "folder of recordings or one recording (all of it fits)")
    p.add_argument("--train", metavar="FILE", help="wpi: the training file")
    p.add_argument("--test", metavar="PATH",
                   help="wpi: the test file (published protocol); csv: test recordings (file "
                        "or folder) instead of the dataset's test split")
    p.add_argument("--select", action="store_true",
                   help="choose the model variant on the training data only (never the test "
                        "ones): csv by blocked 5-fold cross-validation over the recordings, wpi "
                        "by phase cross-validation within the training file; slower")
    p.add_argument("--gravity", type=float, nargs=3, metavar=("GX", "GY", "GZ"),
                   help="csv: gravity in the base (RCM) frame, m/s^2, where the arm's mounting "
                        "is known (e.g. 0 0 -9.81 upright); default: identified")
    p.add_argument("--model-out", help="save the fitted model (JSON) here")
    p.add_argument("--accept-poor-fit", action="store_true",
                   help="save the model (and exit 0) even when its relative torque error exceeds "
                        "the poor-fit threshold on every coordinate (psmforce.identification."
                        "dynamics_report.POOR_FIT_RELATIVE_ERROR_PERCENT)")
    p.add_argument("--json", help="write the report here")

    p = add("wrench", offline.wrench_command, "external wrench on the tool from joint torques",
            "Per sample of a recording: the wrench the environment applies on the tool, from the "
            "joint efforts minus the identified arm dynamics (fit-dynamics), solved through the "
            "PSM Jacobian with damping near singularities. Writes time, ext_fx ext_fy ext_fz "
            "(N), ext_tx ext_ty ext_tz (Nm), sigma_min (smallest singular value of the "
            "Jacobian) and damped (0/1). Signals are low-passed zero-phase at the model's "
            "cutoff (offline).")
    p.add_argument("recording", help="recording CSV in our layout")
    p.add_argument("--dynamics", required=True, metavar="ARM.json",
                   help="arm model written by fit-dynamics --model-out")
    p.add_argument("--out", required=True, metavar="FILE.csv", help="CSV file to write")
    # the choices are psmforce.robot.conventions' NAMED_FRAMES and EXPRESSED_IN, written out so that
    # the parser does not load psmforce.robot (Pinocchio); tests/robot/test_conventions.py keeps them equal
    p.add_argument("--frame", choices=["cp", "jaw_tip", "roll", "hex10"], default="cp",
                   help="reference frame: its origin is the moment's point (default cp)")
    p.add_argument("--expressed-in", choices=["frame", "base", "base_at_frame"], default="frame",
                   help="frame: the frame's axes (default); base: moment about the RCM, base "
                        "axes; base_at_frame: moment about the frame's origin, base axes")
    p.add_argument("--json", help="write a summary here")

    p = add("index", offline.index_command, "make a folder of your own recordings a dataset",
            "Write DIR/metadata.json listing every recording CSV under DIR, its condition from its "
            "folder (Free, Traction, Palpation, ...) and its split from the folder above (train, "
            "test, config_k). train / finetune / evaluate read only folders with a metadata.json "
            "(simulate writes one last, so an interrupted run is never read half).")
    p.add_argument("data", metavar="DIR", help="folder of recordings: DIR/SPLIT/CONDITION/*.csv")
    p.add_argument("--json", help="write the list of trials here")

    p = add("fit-prior", offline.fit_prior_command, "fit the internal-force prior (CasADi)",
            "Fit the instrument's internal-force prior (what the HEX10 reads with no external "
            "force) on the free-space recordings of a dataset folder; writes the model as JSON.")
    p.add_argument("--data", required=True, help="dataset folder (as written by simulate)")
    p.add_argument("--out", required=True, help="prior JSON to write")
    p.add_argument("--use-loaded", action="store_true", help="also fit on Traction/Palpation "
                   "trials with the known ATI force subtracted (excites the pulley radii)")
    p.add_argument("--load-path", action="store_true", help="read the cables from the trials' "
                   "known tip force, not the motor efforts (an identification of the "
                   "instrument; no estimator runs on it): docs/identification.md section 2.3")
    p.add_argument("--accept-poor-fit", action="store_true", help="save the prior even when its "
                   "test Free force RMS exceeds the poor-fit threshold (prior_report.POOR_FIT_RMS_N)")
    p.add_argument("--identify", action="store_true", help="identification: hold the parameters "
                   "the identifiability report calls unidentifiable at their design values and "
                   "refit the rest, naming both (docs/identification.md section 2); default: all "
                   "free but what the reading holds: a curve fit, which the verdict line says")
    p.add_argument("--crosstalk", choices=list(options.CROSSTALK_OPTIONS), default="reading",
                   help="the HEX10's cross-talk the law fits: as the reading does (the load path "
                   "fits its axial column, the efforts reading none), none, the axial column, "
                   "or every force column (full)")
    p.add_argument("--json", help="write the fit statistics here")

    p = add("fit-transmission", offline.fit_transmission_command,
            "identify an instrument's cable transmission, motor to jaw (CasADi)",
            "Fit the cable-transmission model (psmforce/identification/transmission/model.py: "
            "capstan pair law, Dahl friction memory, stick hold, backlash, compliance) on one or "
            "more session folders of XY.TXT or ZXY.TXT recordings in the MRD Lab layout (motor "
            "current, command and encoder in, jaw torque and angle as truth; "
            "psmforce/identification/transmission/recording.py): the instrument's constants once "
            "over every folder, the per-session parameters (pretension, torque sensor zero, jaw "
            "encoder zero) per folder. With --recalibrate MODEL, only the per-session "
            "parameters are fitted, on a short segment of a new session. Files that fail a data "
            "check (drive saturation, overspeed, encoder jumps, torque saturation, current "
            "excursion; psmforce/identification/transmission/checks.py) are left out and named. "
            "Writes the model as JSON with the fit's identifiability report.")
    p.add_argument("session", metavar="DIR", nargs="+",
                   help="folder(s) of XY.TXT / ZXY.TXT files, one session each")
    p.add_argument("--out", required=True, help="model JSON to write")
    p.add_argument("--validation", nargs="*", default=[], metavar="XY",
                   help="files held out to choose the hysteresis widths, by name (02 12) or, "
                        "with several folders, FOLDER/XY (default: none, the widths are "
                        "chosen on the fit data)")
    p.add_argument("--recalibrate", metavar="MODEL",
                   help="a fitted model: keep its constants, fit only the per-session "
                        "parameters of DIR (a short segment after mounting)")
    p.add_argument("--current-source", choices=("command", "measured"), default="command",
                   help="the drive current the law reads: the drive's command times its "
                        "current gain (default; no sensor offset between sessions) or the "
                        "measured current")
    p.add_argument("--fix", action="append", default=[], metavar="NAME=VALUE",
                   help="hold a torque parameter at a value (repeatable), e.g. "
                        "position_stiffness=0")
    p.add_argument("--bootstrap", type=int, default=0, metavar="N",
                   help="measure identifiability by refitting on N resamplings of the files; "
                        "a parameter it cannot pin down is fixed at its design value and "
                        "named (default 0: not measured)")
    p.add_argument("--keep-flagged", action="store_true",
                   help="fit on files that fail a data check too (default: left out, named)")
    p.add_argument("--rate-hz", type=float, default=100.0,
                   help="sample rate the files are resampled to (must divide 1000; default 100)")
    p.add_argument("--json", help="write the parameters and scores here")

    p = add("train", offline.train_command, "train an estimator",
            "Train one estimator (a model of psmforce/estimators/networks/recipes.py) on a dataset folder; writes a "
            "checkpoint holding weights, features, scalers, prior and provenance.")
    p.add_argument("--data", required=True)
    p.add_argument("--model", default="hybrid_transformer",
                   help="a model of the recipe table, psmforce.estimators.networks.recipes.RECIPES "
                        "(default hybrid_transformer: the hybrid's physics read by the paper's "
                        "transformer; hybrid: its causal network, far quicker to train)")
    p.add_argument("--out", required=True, help="checkpoint file to write")
    p.add_argument("--features", help="feature set name (default: the model's own inputs, the "
                                       "paper's for most)")
    p.add_argument("--prior", help="prior JSON (hybrid_transformer, hybrid; default: fit one on "
                                    "the data's free space)")
    p.add_argument("--prior-crosstalk", action="store_true",
                   help="the fitted prior also fits the HEX10's cross-talk of fz into the other "
                        "channels (docs/identification.md; default: held at 0, as every "
                        "committed comparison was trained)")
    p.add_argument("--config", metavar="JSON",
                   help="the model constructor's keyword arguments as a JSON object, inline or "
                        "a file holding one, e.g. '{\"uncertainty\": true}' for a hybrid that "
                        "also predicts the std of its estimate (psmforce/estimators/networks/uncertainty.py); checked "
                        "before any data is read (default: the model's defaults)")
    training_arguments(p, "training statistics")

    p = add("finetune", offline.finetune_command, "finetune an estimator on new recordings",
            "Freeze all but the last decoder block of a trained estimator and train it on a new "
            "dataset folder (e.g. a new PSM configuration); for rocket, refit the ridge on its "
            "frozen features.")
    p.add_argument("checkpoint")
    p.add_argument("--data", required=True)
    p.add_argument("--out", required=True, help="checkpoint file to write")
    training_arguments(p, "finetuning statistics")

    p = add("calibrate", offline.calibrate_command, "calibrate an estimator to another instrument",
            "Few-shot calibration to a new tool from the first --minutes of its calibration trials: "
            "the train split's Free and Traction recordings of DATA, interleaved by minutes in metadata.json "
            "order (psmforce/estimators/training/calibrate.py states the rule). The hybrid's internal-force "
            "prior is refitted on them; every model's last block is finetuned on them (rocket: its "
            "ridge), with early stopping on a validation split of the same trials. The checkpoint's "
            "provenance names the trials and minutes. The same tool re-mounted: psmforce remount.")
    p.add_argument("checkpoint", help="trained checkpoint (the old tool)")
    p.add_argument("--data", required=True, metavar="NEW_TOOL_DIR",
                   help="dataset folder recorded with the new tool")
    p.add_argument("--out", required=True, help="checkpoint file to write")
    p.add_argument("--minutes", type=float, default=5.0,
                   help="minutes of calibration trials to use (default 5: on the simulated bench "
                        "at scale 1, one free-space replay and four traction trials)")
    p.add_argument("--free-space", action="store_true",
                   help="calibrate without an ATI: DATA's train/Free recordings only, their "
                        "external force 0 N by declaration (docs/ati_free.md)")
    p.add_argument("--known-loads", metavar="LOADS_DIR",
                   help="with --free-space: also a dataset folder of known masses hung at the "
                        "tip, each metadata.json trial entry (train/KnownLoad) with its mass as "
                        "'known_load_kg'; the force is that weight in the HEX10 frame from the "
                        "recorded joints (docs/ati_free.md)")
    p.add_argument("--held-values", choices=options.HELD_VALUES, default="as-held",
                   help="with --known-loads or --prior-refit identified: 'checked' also holds "
                        "what the design values held "
                        "for the instrument, each off by its tolerance, would move beyond its "
                        "needed precision (docs/identification.md section 2; default as-held)")
    p.add_argument("--jackknife-unit", choices=options.JACKKNIFE_UNITS, default="orientation",
                   help="with --known-loads or --prior-refit identified: what the jackknife over "
                        "the weights' orientations "
                        "leaves out at a time: one orientation, or a sign pair (an orientation "
                        "and its opposite, for weights hung in sign pairs; default orientation)")
    p.add_argument("--hold-rule", choices=options.HOLD_RULES, default="imprecise",
                   help="with --known-loads or --prior-refit identified: what the instrument's "
                        "identification holds at "
                        "design values among the parameters it lists for their precision alone: "
                        "every one (imprecise, the default), only those whose design value "
                        "the data do not reject (unresolved), or only those whose design value "
                        "is known at least as well as the data know the estimate "
                        "(least-uncertain); the others kept free, named estimated, and carried "
                        "by --prior-refit identified")
    p.add_argument("--clenched-lateral", action="store_true",
                   help="with --known-loads or --prior-refit identified: the identification "
                        "counts the lateral forces of the samples where the jaws are clenched "
                        "on each other, which pin down the sensor's lateral cross-talk of the "
                        "axial force without a weight (docs/ati_free.md section 4.8)")
    p.add_argument("--free-lateral-offsets", action="store_true",
                   help="with --known-loads or --prior-refit identified: the identification "
                        "never holds the HEX10's lateral force offsets at 0 (the tare's "
                        "residual, this mount's), so the cross-talk beside each does not take "
                        "its share of the rest level (docs/ati_free.md section 4.8)")
    p.add_argument("--prior-refit", choices=options.PRIOR_REFITS, default="all",
                   help="with --free-space: 'identified' holds what the instrument's "
                        "identification through the load path (on the known loads and the "
                        "free space, or on the free space alone) identified at its identified "
                        "values in the estimator's prior and refits the rest (docs/ati_free.md "
                        "sections 4.3 and 4.8); default all, the prior refitted on the efforts "
                        "alone")
    p.add_argument("--network-off", nargs="+", default=["none"], metavar="RULE_OR_AXIS",
                   help="axes whose estimate is the prior alone, the network's residual not "
                        "added: 'carried' (with --prior-refit identified: each lateral axis "
                        "whose cross-talk the identification carried into the prior, "
                        "docs/ati_free.md section 4.5), or axis names (Fx Fy Fz); default none")
    p.add_argument("--no-finetune", action="store_true",
                   help="refit the prior only and keep the network as trained (no epoch runs; "
                        "a model without a prior is refused)")
    p.add_argument("--network-prior", choices=options.NETWORK_PRIORS, default="calibrated",
                   help="with --free-space and --network-off: which prior the network reads, "
                        "the refitted one (calibrated, the default) or the one it was trained "
                        "with (trained: the refitted prior then answers the --network-off axes "
                        "alone, docs/ati_free.md section 4.7)")
    training_arguments(p, "the calibration report")
    remount.add_remount_command(add)  # after a re-mount: the prior's per-mount values only

    p = add("evaluate", offline.evaluate_command, "evaluate an estimator as in the paper",
            "Score RMSE / NRMSE / R^2 per axis on the test recordings of a dataset folder, by "
            "the paper's post-processing (bias from the first 0.5 s, centred median k=71) and "
            "by the causal ones a haptic loop gets (raw; causal 5 Hz low-pass), each beside its "
            "floor; writes tables and plots.")
    p.add_argument("checkpoint")
    p.add_argument("--data", required=True)
    p.add_argument("--out", required=True, help="folder for tables and plots")
    p.add_argument("--allow-train-overlap", action="store_true",
                   help="score even test recordings whose content equals a trial the checkpoint "
                        "was trained or validated on (each is named on stderr); by default such "
                        "a test set is refused, its scores would be leaked")
    p.add_argument("--json", help="write the metrics here")

    p = add("reproduce", offline.reproduce_command, "reproduce the paper's tables on the simulated bench",
            "Simulate a bench per seed, fit the prior, train every model to early stopping, run "
            "the ablations, data efficiency and teleoperation finetuning, score by the causal and "
            "the paper's metrics with their floors; mean +/- std over seeds in markdown + JSON "
            "tables and PNG plots in OUT. Tasks are cached under OUT/work: rerun the same "
            "command to resume an interrupted run.")
    p.add_argument("--out", required=True)
    p.add_argument("--scale", type=float, default=0.1,
                   help="protocol scale (1.0 = the paper's amount of data; default 0.1)")
    p.add_argument("--seeds", type=int, nargs="+", default=[1, 2, 3],
                   help="bench and initialisation seeds, distinct (default 1 2 3; 0 was used in "
                        "design)")
    p.add_argument("--budget", default="full", choices=["full", "cpu", "quick"],
                   help="full: train to early stopping (published); cpu/quick: capped smoke runs")
    p.add_argument("--models", nargs="+",
                   help="models of the recipe table, psmforce.estimators.networks.recipes.RECIPES (default: all)")
    p.add_argument("--no-ablations", action="store_true",
                   help="skip the ablations (the hybrid's variants)")
    p.add_argument("--no-efficiency", action="store_true", help="skip the data-efficiency runs")
    p.add_argument("--no-teleop", action="store_true", help="skip teleoperation finetuning")
    p.add_argument("--port", choices=["none", "cannula", "abdominal-wall"], default="none",
                   help="the cannula every bench of the run passes the shaft through, as "
                        "`simulate --port` (default none: the paper's benchtop); one --out per "
                        "port")
    p.add_argument("--ray", metavar="ADDRESS",
                   help="run the tasks on Ray: 'auto', 'local' or a cluster address "
                        "(pip install 'psmforce[cluster]')")
    p.add_argument("--device", default="cpu", choices=["cpu", "cuda"])
    p.add_argument("--finish-on", choices=["cpu", "cuda"],
                   help="compute the tasks still to do on this device, every task keeping the "
                        "key of --device: a run started on a GPU whose machine is gone "
                        "finishes on the CPU, each training resuming its saved state and "
                        "recording the devices it ran on")
    p.add_argument("--json", help="write all tables here")

    p = add("export", offline.export_command, "export an estimator for C++ / ROS 2",
            "Write the network as ONNX plus a JSON of the prior, scalers and feature order.")
    p.add_argument("checkpoint")
    p.add_argument("--out", required=True, help="folder to write")

    p = add("upgrade-checkpoint", offline.upgrade_checkpoint_command,
            "seal a format 2 checkpoint you trust as format 3",
            "Format 2 checkpoints carry no checksum over their metadata and prior, so they are "
            "refused (docs/integrity.md). This checks what can be checked (the weights' "
            "checksum, the metadata's shape and sense) and writes the same record as format 3, "
            "sealed: you vouch for its content once.")
    p.add_argument("checkpoint")
    p.add_argument("--out", required=True, help="the format 3 checkpoint to write")
    p.add_argument("--json", help="write a summary here")

    p = add("excitation", offline.excitation_command,
            "design a free-space excitation to calibrate the prior without an ATI",
            "Design a joint trajectory (Fourier motions of every joint and jaw clenches at "
            "several grip efforts) chosen for the identifiability of the internal-force prior "
            "(docs/ati_free.md). Writes OUT/excitation.csv (time_s and each joint's setpoint "
            "with its unit), OUT/excitation_bag (ROS 2 MCAP: sensor_msgs/JointState on "
            "/PSM1/servo_jp and /PSM1/jaw/servo_jp) and OUT/excitation.json (segments, the "
            "parameters each excites, condition numbers against a random and the paper's "
            "free-space motion, limits).")
    p.add_argument("--out", required=True, help="output folder (new or empty)")
    # the bounds are psmforce.cli.excitation's MIN/MAX_MINUTES and _WEIGHT_KG, written
    # out so that the parser does not load the library; the library checks them again
    p.add_argument("--minutes", type=options.number_in(0.2, 30.0, low_open=False), default=5.0,
                   help="duration in minutes, 0.2 to 30 (default 5)")
    p.add_argument("--seed", type=int, default=0, help="the design's draws (default 0)")
    p.add_argument("--known-weights", type=options.number_in(0.01, 0.2, low_open=False),
                   nargs="+", default=[], metavar="KG",
                   help="masses (kg, 0.01 to 0.2) you can hang at the tip: the report says what "
                        "each adds in each orientation and how many make the prior identifiable")
    p.add_argument("--paired-poses", action="store_true",
                   help="with --known-weights: sixteen orientations in sign pairs (each bend and "
                        "its opposite), what identifying the instrument through the load path "
                        "needs (docs/ati_free.md section 4.1); default: eight")
    p.add_argument("--json", help="write the report here as well")

    p = add("demo", offline.demo_command, "the main job: a small bench end to end in a few minutes",
            "Simulate a small bench, fit the prior, train the hybrid and a baseline, evaluate "
            "them, print the table and write the plots.")
    p.add_argument("--out", default="out/demo")
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--json", help="write the table here")

    from psmforce.cli.live import add_live_commands  # replay, serve (docs/live.md)
    add_live_commands(sub)
    return parser


def main(argv: list[str] | None = None) -> int:
    args = _parser().parse_args(argv)
    try:
        if args.plugin:
            from psmforce.estimators.networks.recipes import load_plugins
            load_plugins(args.plugin)
        guards.outputs_spare_inputs(args)
        if getattr(args, "json", None):
            options.output_file(args.json, "--json", parents=False)  # before the work, not after it
        result = args.func(args)
        options.write_json(getattr(args, "json", None), result if isinstance(result, dict) else {})
    except KeyboardInterrupt:
        print(f"psmforce {args.command}: interrupted", file=sys.stderr)
        return 130
    except Exception as err:  # noqa: BLE001 - the one error boundary (module docstring)
        if args.debug:
            traceback.print_exc()
        text = str(err).strip()
        reason = text.splitlines()[0][:500] if text else type(err).__name__
        if isinstance(err, (ValueError, OSError, RuntimeError, KeyError)):
            print(f"psmforce {args.command}: error: {reason}", file=sys.stderr)
            return 2
        print(f"psmforce {args.command}: internal error: {type(err).__name__}: {reason} (a bug; "
              f"--debug shows the traceback)", file=sys.stderr)
        return 3
    return 0


if __name__ == "__main__":
    sys.exit(main())
