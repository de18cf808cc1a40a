"""The live commands of the command line: ``psmforce replay`` and ``psmforce serve``.

:func:`add_live_commands` registers them on the ``psmforce`` sub-command parser; each returns a
JSON-ready report (``--json``). A missing optional package (``cyclonedds``, ``foxglove-sdk``,
``mcap``: ``pip install 'psmforce[ros]'``) is one error line, as every other failure.
"""

from __future__ import annotations

import argparse
import contextlib
import json
import signal
import sys
import threading

from psmforce.cli import options


def _needs(module: str, feature: str) -> None:
    import importlib.util
    if importlib.util.find_spec(module) is None:
        raise RuntimeError(f"{feature} needs the '{module}' package: "
                           f"pip install 'psmforce[ros]'")


NETWORK_ORDER = {"before-answer": False, "after-answer": True}
"""``--network``: the estimator's ``network_after_answer``
(:mod:`psmforce.estimators.runtime.streaming`)."""


def _topics(args) -> dict:
    return {k: v for k, v in (("js", args.topic_js), ("jaw", args.topic_jaw),
                              ("hex10", args.topic_hex10)) if v is not None}


def replay_command(args) -> dict:
    _needs("mcap", "replay")
    if args.view:
        _needs("foxglove", "replay --view")
    from psmforce.live.replay import replay
    topics = _topics(args) | ({"ati": args.topic_ati} if args.topic_ati else {})
    if args.view:
        print(f"replay --view: Foxglove WebSocket on ws://127.0.0.1:{args.port}; playing once a "
              f"client subscribes to /{args.arm.strip('/')}/tool_force/hex10 (at most "
              f"{args.view_wait:g} s from now), serving until interrupted", flush=True)
    report = replay(args.bag, _checkpoint(args, False), args.out, arm=args.arm, topics=topics,
                    input_rate_hz=args.input_rate, post_filter=args.post_filter,
                    tare_on_start=args.tare_on_start, sync=args.sync_stamps,
                    realtime=args.realtime, network_after_answer=NETWORK_ORDER[args.network],
                    view_port=args.port if args.view else None, view_wait_s=args.view_wait,
                    view_hold_s=None)
    print(f"wrote {report['out']} ({report['answers']} estimates at "
          f"{report['input_rate_hz']:.4g} Hz, model at {report['model_rate_hz']:g} Hz) and "
          f"{report['layout']}" + (f"; skipped {sum(report['malformed'].values())} messages "
                                   f"that did not decode" if report["malformed"] else ""))
    return report


def serve_command(args) -> dict:
    _needs("cyclonedds", "serve")
    stop = threading.Event()
    with _stop_on_signals(stop):  # from the start: a signal while loading still ends in a report
        report = _serve(args, stop)
    print(json.dumps({k: report[k] for k in ("received", "malformed", "answers_published",
                                             "unpaired", "input_rate_hz", "model_rate_hz",
                                             "decimation", "lag_s") if k in report}))
    return report


def _checkpoint(args, simulated: bool) -> str:
    """The checkpoint a live command runs: the one given, else (``serve --sim``) the shipped
    bench model; a bench model on a real robot's topics only with ``--bench-model``."""
    from psmforce.estimators.training.checkpoint import load_checkpoint
    from psmforce.live.bench_model import check_use, shipped_checkpoint
    if args.checkpoint is None:
        if not simulated:
            raise ValueError("give a checkpoint (psmforce train); or run with --sim to see the "
                             "shipped bench model answer a simulated robot")
        return str(shipped_checkpoint())
    check_use(load_checkpoint(args.checkpoint).provenance, args.checkpoint,
              simulated=simulated, allowed=args.bench_model)
    return args.checkpoint


def _serve(args, stop: threading.Event) -> dict:
    from psmforce.live.discovery import discovery, domain, participant as join
    from psmforce.live.scheduling import check_busy_poll, run_realtime
    from psmforce.live.serve import DdsNode
    if args.busy_poll:   # refused before the scheduling changes, not once the node is built
        check_busy_poll(args.rt_priority is not None)
    checkpoint = _checkpoint(args, args.sim)
    scheduling = run_realtime(args.rt_priority)   # before the participant: its threads inherit
    participant = join(args.domain_id)
    node = DdsNode(checkpoint, participant, arm=args.arm, topics=_topics(args),
                   input_rate_hz=args.input_rate, tare_on_start=args.tare_on_start,
                   tare_s=args.tare_s, reader_best_effort=args.reader_qos == "best-effort",
                   writer_best_effort=args.writer_qos == "best-effort",
                   sync=args.sync_stamps or args.sim, sync_wait_s=args.sync_wait,
                   domain_id=domain(args.domain_id), post_filter=args.post_filter,
                   network_after_answer=NETWORK_ORDER[args.network], busy_poll=args.busy_poll)
    print(f"psmforce serve: domain {domain(args.domain_id)}, discovery "
          f"{discovery()[0].lower()}, listening on "
          f"{', '.join(node.input_topics.values())}; publishing "
          f"{node.output_topics['hex10']} and {node.output_topics['base']}", flush=True)
    player = _start_sim(args, participant, stop) if args.sim and not stop.is_set() else None
    try:
        return {**node.spin(duration_s=args.duration, stop=stop, idle_stop_s=args.idle_stop,
                            progress_s=None if args.quiet else 1.0), "scheduling": scheduling}
    finally:
        stop.set()
        if player is not None:
            player.join(5)


@contextlib.contextmanager
def _stop_on_signals(stop: threading.Event):
    """SIGINT (Ctrl-C) and SIGTERM (a launcher, ``kill``, systemd) set ``stop``: the node ends
    its loop, stops the simulated robot, and the command writes its report and ``--json`` as
    at the end of ``--duration``. Raising ``KeyboardInterrupt`` instead would land anywhere,
    inside the middleware's calls included, and leave no report. A second signal while
    stopping is the impatient user's: it interrupts at once. A SIGINT the shell set to be
    ignored (a background job) stays ignored."""
    def on_signal(signum, frame):
        if stop.is_set():
            raise KeyboardInterrupt
        stop.set()
        print(f"psmforce serve: {signal.Signals(signum).name}: stopping, writing the report",
              file=sys.stderr, flush=True)

    handled = [signal.SIGTERM] + ([signal.SIGINT] if signal.getsignal(signal.SIGINT)
                                  is not signal.SIG_IGN else [])
    before = {s: signal.signal(s, on_signal) for s in handled}
    try:
        yield
    finally:
        for s, handler in before.items():
            signal.signal(s, handler)


def _start_sim(args, participant, stop: threading.Event) -> threading.Thread:
    """The simulated robot, in a thread of this process publishing on the same domain."""
    from psmforce.io.recording import read_recording
    from psmforce.live.sim_robot import bench_recording, play
    frame = (read_recording(args.sim_recording, require_targets=False) if args.sim_recording
             else bench_recording(args.sim_rate))
    thread = threading.Thread(target=play, args=(frame, participant),
                              kwargs={"arm": args.arm, "topics": _topics(args), "loop": True,
                                      "stop": stop}, daemon=True)
    thread.start()
    return thread


def _common(p: argparse.ArgumentParser, *, shipped: bool = False) -> None:
    if shipped:
        p.add_argument("checkpoint", nargs="?",
                       help="a checkpoint of a model that streams (psmforce train: the hybrid, the "
                            "paper's transformer or the FCN); with --sim it may "
                            "be left out: the shipped bench model answers")
    else:
        p.add_argument("checkpoint", help="a checkpoint of a model that streams (psmforce train: "
                                          "the hybrid, the paper's transformer or the FCN)")
    p.add_argument("--bench-model", action="store_true",
                   help="run a checkpoint trained on the simulated bench only (the shipped "
                        "one) on these topics anyway: its forces are the simulator's "
                        "instrument's, not yours")
    p.add_argument("--arm", default="PSM1", type=options.ros_name(namespace=True), help="arm namespace (default PSM1)")
    p.add_argument("--topic-js", type=options.ros_name(), help="arm JointState topic (default /ARM/measured_js)")
    p.add_argument("--topic-jaw", type=options.ros_name(), help="jaw JointState topic (default /ARM/jaw/measured_js)")
    p.add_argument("--topic-hex10", type=options.ros_name(), help="HEX10 WrenchStamped topic (default /hex10/measured_cf)")
    p.add_argument("--input-rate", type=options.RATE_HZ, metavar="HZ",
                   help="the HEX10 stream's rate (default: measured from its stamps); a whole "
                        "multiple of the model's training rate")
    p.add_argument("--post-filter", default="none", choices=["none", "median", "lowpass"])
    p.add_argument("--network", choices=list(NETWORK_ORDER), default="before-answer",
                   help="when the network steps on the sample it is due for (one in D, the "
                        "input rate over the model's): before-answer (default), or "
                        "after-answer: that sample is answered with the step before's "
                        "residual and its own step runs once the answer is out, one input "
                        "period more of lag on the residual (docs/live.md)")
    p.add_argument("--tare-on-start", action="store_true",
                   help="tare on the first 0.5 s after warm-up: the arm still, touching nothing")
    p.add_argument("--sync-stamps", action="store_true",
                   help="pair the streams by header stamp, for streams stamped on one clock "
                        "(a simulated robot; --sim sets it); default: the latest of each")
    p.add_argument("--json", help="write the report here")


def add_live_commands(sub) -> None:
    """Register ``replay`` and ``serve`` on the ``psmforce`` sub-command parser ``sub``."""
    p = sub.add_parser(
        "replay", help="play a bag through the live node, write the estimates as MCAP",
        description="Play a recorded session (ROS 2 / ROS 1 bag) through the same code as "
                    "'psmforce serve' and write OUT.mcap (ROS 2 MCAP: the inputs and the "
                    "estimates, both frames, std, flags; docs/live.md) and OUT.layout.json "
                    "(a Foxglove layout).")
    p.add_argument("bag")
    _common(p)
    p.add_argument("--out", required=True, help="the .mcap file to write")
    p.add_argument("--topic-ati", type=options.ros_name(), help="ATI WrenchStamped topic (default /ati/measured_cf)")
    p.add_argument("--realtime", action="store_true", help="play at the recorded pace")
    p.add_argument("--view", action="store_true",
                   help="serve the messages live to Foxglove (WebSocket, --port) while playing, "
                        "and until interrupted")
    p.add_argument("--port", type=options.number_in(0, 65535, low_open=False, integer=True),
                   default=8765, help="--view's port (default 8765; 0: any free port)")
    p.add_argument("--view-wait", type=options.number_in(0.0, options.MAX_SECONDS,
                                                          low_open=False),
                   default=60.0, metavar="S",
                   help="with --view: wait up to S s for a client to subscribe to the estimate "
                        "before playing (default 60; 0: play at once)")
    p.set_defaults(func=replay_command)

    p = sub.add_parser(
        "serve", help="the live force estimator node over DDS (ROS 2)",
        description="Subscribe to the dVRK's joint states and the HEX10 over DDS (ROS 2 "
                    "topics), publish the tool force in the base and HEX10 frames, its std and "
                    "flags (docs/live.md). Needs pip install 'psmforce[ros]'.")
    _common(p, shipped=True)
    p.add_argument("--tare-s", type=options.number_in(0.0, 3600.0), default=0.5,
                   help="tare duration (default 0.5 s)")
    p.add_argument("--sync-wait", type=float, default=0.1, metavar="S",
                   help="with --sync-stamps: how long a HEX10 message waits for the arm's and "
                        "jaw's messages of its stamp before it is answered without them "
                        "(counted as unpaired; default 0.1 s)")
    p.add_argument("--domain-id", type=options.number_in(0, 232, low_open=False, integer=True),
                   help="DDS domain, 0 to 232 (default: ROS_DOMAIN_ID, else 0)")
    p.add_argument("--reader-qos", choices=["reliable", "best-effort"], default="reliable",
                   help="the node's readers: reliable (default; matches the dVRK's reliable "
                        "publishers) or best-effort (also matches sensor-data QoS publishers)")
    p.add_argument("--writer-qos", choices=["reliable", "best-effort"], default="reliable",
                   help="the node's writers: reliable (default; every subscriber matches) or "
                        "best-effort (only best-effort subscribers match)")
    p.add_argument("--best-effort", dest="reader_qos", action="store_const",
                   const="best-effort", help="the same as --reader-qos best-effort (the "
                   "writers stay reliable)")
    p.add_argument("--rt-priority", type=options.number_in(1, 99, low_open=False,
                                                           integer=True), metavar="N",
                   help="run the node under Linux's SCHED_FIFO at priority N (1-99), ahead of "
                        "every normal process: a short tail on a busy host (needs an rtprio "
                        "limit or CAP_SYS_NICE; docs/live.md)")
    p.add_argument("--busy-poll", action="store_true",
                   help="poll for messages instead of sleeping between them: a shorter "
                        "latency tail for a whole core's time (for a core set aside for the "
                        "node; docs/live.md)")
    p.add_argument("--duration", type=options.SECONDS, metavar="S", help="stop after S seconds")
    p.add_argument("--idle-stop", type=options.SECONDS, metavar="S",
                   help="stop when no message came for S seconds after the first")
    p.add_argument("--sim", action="store_true",
                   help="also run a simulated dVRK + HEX10 publishing a bench session")
    p.add_argument("--sim-rate", type=options.RATE_HZ, default=1000.0,
                   help="the simulated robot's rate (default 1000 Hz)")
    p.add_argument("--sim-recording", help="with --sim: publish this recording CSV instead")
    p.add_argument("--quiet", action="store_true",
                   help="no progress line each second (answers per second, the latest force)")
    p.set_defaults(func=serve_command)
