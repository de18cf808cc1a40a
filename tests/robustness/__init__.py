"""Robustness: bad input against the command line and the Python API (issue 14), every case
runnable and classified automatically, one module per artefact (:mod:`tests.robustness.cases`);
and the streaming estimator under 10^6 adversarial samples (:mod:`.adversarial_stream`).

    python -m tests.robustness [--json results/benchmarks/fuzz.json] [--only TEXT]
    python -m tests.robustness.adversarial_stream [--samples 1000000]

Builds once, in a temporary folder, a tiny simulated bench (scale 0.005, seed 0: 20 recordings of
240-1120 samples), a nominal prior (default parameters, the insertion model at physical values)
and two one-epoch checkpoints (fcn, hybrid); then runs each case in its own folder, CLI cases
in-process (``psmforce.cli.main.main``, stdout and stderr captured). Verdicts:

REJECTED  exit 2 (CLI) or a library error (a ValueError or OSError: the library's own error
          types derive from ValueError) whose one-line message names the file or option the
          case names, and every file in the case's folder and the shared inputs unchanged;
HANDLED   accepted, and the case's own check of the output holds (output correct, or the problem
          flagged in it);
UNCLEAR   rejected, but the message is not one line naming the file or option;
SILENT    accepted with wrong, NaN or misleading output, or rejected leaving files behind;
CRASH     a traceback: an exception the CLI does not catch, or from the API one that is not a
          library error (TypeError, IndexError, AttributeError, ...), or an exit code not 0 / 2
          (3 is the CLI's "internal error": a bug its error boundary caught);
LOSS      a file the user had (in the case's folder, the shared inputs or beside the cases) changed
          or disappeared, byte for byte, whatever the verdict otherwise: only the files the
          command is asked to write (``--out``, ``--json``, ``--model-out``, or a call's declared
          outputs) may be replaced;
ESCAPE    the case reached outside its folder: a file changed in the shared inputs or in the
          ``outside`` folder beside the cases, or a case that points a file outside its folder
          (an export's graph) was accepted.

Issue 26 added the classes of the integrity cases: checkpoints with one metadata field edited, a
non-integer format version or a config out of range (some resealed, as a careless tool would); model
configs; timestamps that overflow the stream's gap arithmetic; the export runner (edited or foreign
folders, a graph outside its folder, bad recordings); outputs naming an input; repeated seeds;
degenerate targets and train/test overlap; edited cached task results; fits that must print their
verdict. Further cases go beyond the issue's report: prior files with one field edited or a version
that is not the integer, timestamps on a decimating stream and on a clock past float resolution,
array samples of a non-real dtype, tables the export runner cannot read as the stream would (a
column twice, complex, no rows), repeated seeds from Python.

Each case also states the verdict it should get (REJECTED or HANDLED). Cases whose acceptance
would start expensive work (a simulation at scale 1e6, a reproduce run) patch that work to raise
:class:`Reached`: reaching it with the bad input is SILENT. Prints the counts and every case that
is not REJECTED or HANDLED (and any verdict other than expected), writes the JSON, exits 1 if any
case is SILENT, UNCLEAR, CRASH, ESCAPE or LOSS or differs from its expected verdict.
"""
