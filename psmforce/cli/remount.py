"""``psmforce remount``: after re-mounting the instrument, the checkpoint's prior recalibrated per
mount (:mod:`psmforce.estimators.training.remount`; docs/ati_free.md section 5, step 8).

Its own command rather than a flag of ``calibrate``: ``calibrate`` fits a model trained on
another instrument to this one (the prior refitted and the network's last block finetuned, with
its epochs, seed, device and minutes), a re-mount keeps the instrument and the network and moves
four numbers of the prior; none of ``calibrate``'s training options would apply. The parser is
registered from :mod:`psmforce.cli.main`; the library is imported only when the command runs, so
``psmforce --help`` stays fast.
"""

from __future__ import annotations

DESCRIPTION = (
    "After re-mounting the instrument (removed, re-attached, HEX10 zeroed: the paper's reset "
    "before every trial), re-estimate only what a re-mount changes in the checkpoint's "
    "internal-force prior: the cable pretension and the three HEX10 force offsets "
    "(psmforce.identification.prior_remount.FORCE_PER_MOUNT), on free-space recordings of the "
    "new mount: about 2 minutes of 'psmforce excitation --minutes 2' played on the arm, touching "
    "nothing, converted to the recording CSV layout. Every other prior parameter (the moment "
    "offsets included), the insertion model, the network's weights, features and scalers stay "
    "the checkpoint's. Prints the four values before and after and what was held, and writes a "
    "NEW checkpoint (never over an existing file) that serve, replay, evaluate and export read "
    "like any other; its provenance appends the recalibration to 'remounts'. How: "
    "prior_remount.recalibrate with no mount angle, not 'calibrate --free-space', which would "
    "also finetune the network and needs two recordings; the tilt is not fitted because a "
    "checkpoint's prior has no mount angles to store it in (docs/ati_free.md sections 3 and 5).")


def add_remount_command(add) -> None:
    """Register ``remount`` with ``add`` (:func:`psmforce.cli.main._parser`'s sub-command
    helper: name, handler, help line, description)."""
    p = add("remount", remount_command,
            "recalibrate a hybrid's prior after re-mounting the instrument", DESCRIPTION)
    p.add_argument("checkpoint", help="the instrument's trained hybrid (read, never written)")
    p.add_argument("--data", required=True, metavar="DIR|FILE",
                   help="free-space recordings of the new mount: one recording CSV, or a folder "
                        "(its Free recordings, DIR/[SPLIT/]Free/*.csv or as its metadata.json "
                        "says, else the CSV files directly in it)")
    p.add_argument("--out", required=True, metavar="NEW.pt",
                   help="the checkpoint to write: a new file (an existing one is refused; there "
                        "is no overwrite option)")
    p.add_argument("--json", help="write the recalibration record here")


def remount_command(args) -> dict:
    from psmforce.cli import options
    from psmforce.cli.guards import progress
    options.output_file(args.out, "--out")
    from psmforce.estimators.training.remount import (SUGGESTED_MINUTES, check_out,
                                                      recalibrate_checkpoint)
    check_out(args.out, args.checkpoint)  # before reading anything: no overwrite option
    with progress("remount"):
        record = recalibrate_checkpoint(args.checkpoint, args.data, args.out)
    n = len(record["recordings"])
    print(f"recalibrated the prior of {args.checkpoint} for a new mount on {n} free-space "
          f"recording{'s' * (n != 1)} of {args.data} ({record['minutes']:.2f} min, "
          f"{record['n_samples']} samples):")
    for name in record["re_estimated"]:
        before, after = record["before"][name], record["after"][name]
        se = record["standard_errors"][name]
        print(f"  {name:<17} {before:+9.4f} N -> {after:+9.4f} N  (change {after - before:+.4f}, "
              f"standard error {'n/a' if se is None else format(se, '.2g')})")
    rms = record["free_space_rms_n"]
    print("prior's free-space force RMS on these recordings: "
          + ", ".join(f"{a} {rms['before'][a]:.3g} -> {rms['after'][a]:.3g}" for a in rms["before"])
          + " N (after: in-sample)")
    print("held at the checkpoint's values: " + ", ".join(record["held"])
          + "; not fitted: the mount angles (the checkpoint's prior has none); kept: "
          + record["kept"])
    print("at a bound: " + (", ".join(record["at_bound"]) or "none"))
    if record["minutes"] < SUGGESTED_MINUTES:
        print(f"note: {record['minutes']:.2f} min of recordings; the procedure records "
              f"{SUGGESTED_MINUTES:g} min of the excitation (docs/ati_free.md section 5)")
    print(f"wrote {args.out}")
    return record
