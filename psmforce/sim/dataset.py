"""``simulate``: run a protocol on the simulated bench and write the dataset folder.

Layout (team contract): DIR/metadata.json; automated:
DIR/{train,test}/{Free,Traction,Palpation}/*.csv (validation is split from train at load time);
teleop: DIR/config_{0,1,2}/{Rigid,Soft,Free}/demo_{k}.csv. Every CSV follows psmforce.io.recording
and is written atomically by its ``write_recording``; metadata.json is written last (a folder
without it is an interrupted run).

``fmt="mcap"`` writes each trial as a ROS 2 MCAP bag folder instead (the CSV path without
``.csv``; psmforce.io.bags.writing: the dVRK CRTK topics a real bench records), the trials one after
another on one session clock, plus ``R_ati_psm.json`` (the ATI fixture calibration ``psmforce
convert --r-ati-psm`` takes); ``metadata.json`` lists the bag folders and how to convert them.
"""

from __future__ import annotations

import importlib.metadata
import json
import math
import numbers
import os
import time
from pathlib import Path

import numpy as np

import psmforce.sim.protocols as protocols
import psmforce.sim.versions as versions

from psmforce.robot.conventions import GRAVITY_UPRIGHT_MPS2
from psmforce.core.files import folder_is_empty, locked_folder, write_text_atomic
from psmforce.io.recording import OVERLOAD, TIME, write_recording
from psmforce.sim.bench import run_trajectory
from psmforce.sim.mounting import Remount
from psmforce.sim.params import Effects, InstrumentParams
from psmforce.sim.port import PORT_NAMES, port_by_name

SIM_VERSION = "2.1"
"""2.1: cable stiffness calibrated on a real EndoWrist (6.0e5 -> 2.8e5 N/m; pitch path mismatch
1.5 -> 3.2 um to keep its tension); docs/simulator.md, "Cable law against a real EndoWrist"."""
PROTOCOLS = ("automated", "teleop")
FORMATS = ("csv", "mcap")
BAG_SESSION_START_NS = 1_748_854_800 * 10**9
"""``fmt="mcap"``: header stamp of the first trial's first sample (2025-06-02 09:00:00 UTC)."""
BAG_TRIAL_PAUSE_S = 10.0
"""``fmt="mcap"``: the pause between one trial's last sample and the next trial's first."""
R_ATI_PSM_FILE = "R_ati_psm.json"


MAX_SCALE = 10.0
"""Protocol scales above this are refused before anything is allocated: 10 is ten times the
paper's protocol (about 33 h of 100 Hz data, some 17 million rows, several GB of CSV); larger
values are typos (1e6 ran out of memory half-way)."""

MAX_SEED = 2**32 - 1
"""numpy's generators take seeds in [0, 2**32 - 1]; outside it they fail with a message that
names no option."""


def check_scale_and_seed(scale, seed, seed_name: str = "seed") -> None:
    """Raise :class:`SimulationConfigError` naming ``scale`` or the seed (as ``seed_name``) when
    a bench could not be simulated with them (callers that simulate later, such as reproduce,
    check first)."""
    if (isinstance(scale, bool) or not isinstance(scale, numbers.Real) or not math.isfinite(scale)
            or not 0 < scale <= MAX_SCALE):
        raise SimulationConfigError(f"scale: must be a finite number in (0, {MAX_SCALE:g}], "
                                    f"got {scale!r}")
    if isinstance(seed, bool) or not isinstance(seed, numbers.Integral) or not 0 <= seed <= MAX_SEED:
        raise SimulationConfigError(f"{seed_name}: must be an integer in [0, {MAX_SEED}], got "
                                    f"{seed!r}")


class SimulationConfigError(ValueError):
    """Invalid simulate() arguments; raised before anything is written."""


def _package_version() -> str:
    try:
        return importlib.metadata.version("psmforce")
    except importlib.metadata.PackageNotFoundError:
        return "unknown (not installed)"


def _check_out(out) -> Path:
    if out is None:
        raise SimulationConfigError("out: an output folder is required")
    path = Path(out)
    if path.exists():
        if not path.is_dir():
            raise SimulationConfigError(f"out: {path} exists and is not a folder")
        if not folder_is_empty(path):
            raise SimulationConfigError(f"out: {path} is not empty (refusing to mix datasets)")
        if not os.access(path, os.W_OK | os.X_OK):
            raise SimulationConfigError(f"out: {path} is not writable")
        return path
    parent = path.parent
    while not parent.exists():
        parent = parent.parent
    if not parent.is_dir() or not os.access(parent, os.W_OK | os.X_OK):
        raise SimulationConfigError(f"out: cannot create {path}: {parent} is not a writable folder")
    return path


def _validate(protocol, scale, seed, out, instrument, effects, port):
    if port not in PORT_NAMES:
        raise SimulationConfigError(f"port: unknown {port!r}, expected one of {PORT_NAMES}")
    if protocol not in PROTOCOLS:
        raise SimulationConfigError(f"protocol: unknown {protocol!r}, expected one of {PROTOCOLS}")
    check_scale_and_seed(scale, seed)
    if instrument is not None and not isinstance(instrument, InstrumentParams):
        raise SimulationConfigError(f"instrument: expected InstrumentParams or None, got {type(instrument).__name__}")
    if effects is not None and not isinstance(effects, Effects):
        raise SimulationConfigError(f"effects: expected Effects or None, got {type(effects).__name__}")
    return _check_out(out)


def _check_tool(tool_seed, tool_spread) -> dict | None:
    """The ``metadata["tool"]`` entry of a drawn tool (None: the instrument as given)."""
    if tool_seed is None:
        return None
    if isinstance(tool_seed, bool) or not isinstance(tool_seed, numbers.Integral) or tool_seed < 0:
        raise SimulationConfigError(f"tool_seed: must be an integer >= 0 or None, got {tool_seed!r}")
    if (isinstance(tool_spread, bool) or not isinstance(tool_spread, numbers.Real)
            or not math.isfinite(tool_spread) or tool_spread < 0):
        raise SimulationConfigError(f"tool_spread: must be a finite number >= 0, got {tool_spread!r}")
    return {"seed": int(tool_seed), "spread": float(tool_spread),
            "drawn_with": "InstrumentParams.sample(seed, spread) around the instrument given "
                          "(nominal by default); 'instrument' holds the drawn parameters"}


def simulate(protocol: str = "automated", scale: float = 1.0, seed: int = 0, out=None,
             instrument: InstrumentParams | None = None, effects: Effects | None = None,
             truth: bool = True, port: str = "none", tool_seed: int | None = None,
             tool_spread: float = 1.0, fmt: str = "csv", version=None) -> dict:
    """Simulate a protocol and write the dataset to ``out`` (must not exist or be empty).

    ``scale`` shrinks the protocol proportionally (1.0 = the paper's size); ``seed`` makes the run
    bit-exact; ``instrument`` defaults to the nominal tool, ``effects`` to everything on; ``truth``
    adds the ``sim_*`` truth columns; ``port`` the cannula the shaft passes through (``"none"``: the
    paper's benchtop; ``"cannula"``, ``"abdominal-wall"``: psmforce/sim/port.py). ``tool_seed``:
    another modified tool, ``instrument.sample(tool_seed, tool_spread)`` (around the nominal tool
    when ``instrument`` is None), recorded as ``metadata["tool"]``; None (default) keeps
    ``instrument`` as given and writes no ``tool`` entry, so the default output is unchanged.
    ``fmt``: ``"csv"`` (default) one recording CSV per trial; ``"mcap"`` one ROS 2 MCAP bag per
    trial on the dVRK topics, to be converted as a real bench's (module docstring). ``version``:
    the simulator version (:mod:`psmforce.sim.versions`: a name or a ``Version``; None, the
    default version): its nominal instrument when ``instrument`` is None, and, where it says so,
    a re-mount before every trial (``Remount.draw_for_trial(seed, index, spread).zeroed``,
    recorded in each trial's ``remount``); ``metadata["simulator_version"]`` is its name, and a
    version other than the default adds its definition as ``metadata["simulator"]``. Returns a
    summary (trials, rows, minutes per split and condition, seconds taken). Raises
    :class:`SimulationConfigError` before writing anything.
    """
    if fmt not in FORMATS:
        raise SimulationConfigError(f"fmt: unknown {fmt!r}, expected one of {FORMATS}")
    try:
        sim_version = versions.version(version)
    except (ValueError, TypeError) as e:
        raise SimulationConfigError(f"version: {e}") from None
    path = _validate(protocol, scale, seed, out, instrument, effects, port)
    with locked_folder(path):  # a second command on this folder is refused while this one runs
        if not folder_is_empty(path):
            raise SimulationConfigError(f"out: {path} is not empty (refusing to mix datasets)")
        port_params = port_by_name(port)
        instrument = instrument or sim_version.instrument()
        tool = _check_tool(tool_seed, tool_spread)
        if tool is not None:
            instrument = instrument.sample(tool_seed, tool_spread)
        effects = effects or Effects()
        start = time.perf_counter()
        plans = protocols.automated(scale, seed) if protocol == "automated" else protocols.teleop(scale, seed)
        trials, minutes, rows = [], {}, 0
        bag_start_ns = BAG_SESSION_START_NS
        for index, plan in enumerate(plans):
            rng = np.random.default_rng([seed, 100, index])
            mounted, remount = instrument, None
            if sim_version.remount_spread > 0:  # the paper's reset before every trial
                remount = Remount.draw_for_trial(seed, index, sim_version.remount_spread)
                mounted = remount.zeroed(instrument)
            frame = run_trajectory(plan.q, protocols.DT, plan.contact, mounted, effects, rng,
                                   r_base_ati=protocols.R_BASE_ATI, truth=truth, port=port_params)
            target = path / plan.path
            target.parent.mkdir(parents=True, exist_ok=True)
            if fmt == "csv":
                write_recording(frame, target)
            else:
                from psmforce.io.bags.writing import write_bag  # the bag stack (rosbags) only for MCAP
                target = target.with_suffix("")
                topics = write_bag(frame, target, start_ns=bag_start_ns)
                bag_start_ns += int(round((frame[TIME].iat[-1] + BAG_TRIAL_PAUSE_S) * 1e9))
            rows += len(frame)
            key = f"{plan.split}/{plan.condition}"
            minutes[key] = minutes.get(key, 0.0) + len(frame) * protocols.DT / 60.0
            trials.append({"path": target.relative_to(path).as_posix(), "split": plan.split,
                           "condition": plan.condition,
                           "rows": len(frame), "contact": plan.contact.kind,
                           "hex10_overload_rows": int(frame[OVERLOAD].sum()), **plan.info,
                           **({} if remount is None else {"remount": remount.to_dict()})})
        metadata = {
            "simulator_version": sim_version.name, "software_version": _package_version(),
            **({} if sim_version.name == SIM_VERSION and sim_version == versions.version()
               else {"simulator": sim_version.to_dict()}),
            "protocol": protocol, "scale": float(scale), "seed": int(seed), "sample_rate_hz": 1.0 / protocols.DT,
            "instrument": instrument.to_dict(), **({} if tool is None else {"tool": tool}),
            "effects": effects.to_dict(),
            "port": {"name": port, **({} if port_params is None else port_params.to_dict())},
            "gravity_base": list(GRAVITY_UPRIGHT_MPS2),
            "R_base_ati": protocols.R_BASE_ATI.tolist(),
            "ati_convention": "ati_raw_* = load the fixture puts on the Nano17 (= minus the force on the "
                              "tool) in the ATI frame; ati_f* = -R_PSM_HEX10(q)^T R_base_ati ati_raw_f",
            "effort_convention": "efforts are what the motors apply: a static external force F on the "
                                 "tool adds -J^T F",
            "format": fmt,
            "trials": trials,
        }
        if fmt == "mcap":
            metadata["bags"] = _bag_session(path, topics)
        write_text_atomic(path / "metadata.json", json.dumps(metadata, indent=1))
        return {"out": str(path), "protocol": protocol, "format": fmt, "trials": len(trials),
                "rows": rows,
                "minutes": {k: round(v, 3) for k, v in sorted(minutes.items())},
                "seconds": round(time.perf_counter() - start, 2)}


def _bag_session(path: Path, topics: dict[str, str]) -> dict:
    """``fmt="mcap"``: write the ATI fixture calibration a lab would hold (R_ati_PSM, the PSM base
    axes in the ATI frame: the transpose of R_base_ati) and describe the bags for metadata.json."""
    from psmforce.io.bags.writing import RECEIVE_LATENCY_NS
    write_text_atomic(path / R_ATI_PSM_FILE, json.dumps(protocols.R_BASE_ATI.T.tolist()) + "\n")
    return {
        "storage": "ROS 2 bag, MCAP (one folder per trial: metadata.yaml + .mcap)",
        "topics": topics,
        "time": "header stamps at the sample instants, trials one after another on one clock",
        "session_start_ns": BAG_SESSION_START_NS, "trial_pause_s": BAG_TRIAL_PAUSE_S,
        "receive_latency_ns": RECEIVE_LATENCY_NS,
        "r_ati_psm": R_ATI_PSM_FILE, "ati_sign": -1,
        "not_in_bags": "hex10_overload and the sim_* truth columns (no dVRK topic carries them)",
        "convert": f"psmforce convert DIR/PATH --out CSV_DIR/PATH.csv --r-ati-psm "
                   f"DIR/{R_ATI_PSM_FILE}, then psmforce index CSV_DIR",
    }
