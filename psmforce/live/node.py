"""The live force node's logic, without a transport: ``psmforce serve`` (DDS) and
``psmforce replay`` (a bag) feed it the same messages and publish what it answers.

:class:`ForceNode` holds the latest message of each input stream (``js``: the arm's
sensor_msgs/JointState, ``jaw``: the jaw's, ``hex10``: the HEX10 geometry_msgs/WrenchStamped;
:mod:`psmforce.io.bags.messages`) and, on each new message of its ``trigger`` stream (default the
HEX10), builds the estimator's sample from the three with
:class:`psmforce.io.bags.messages.SampleArray` (the values of
:func:`psmforce.io.bags.messages.sample_from_messages` as an array; time: the trigger's header
stamp) and steps
the :class:`psmforce.estimators.runtime.streaming.StreamingEstimator` once: one answer per trigger
message, at the input rate, whatever rate the network runs at (the estimator decimates,
:mod:`psmforce.estimators.data.rates`). Nothing is answered until each stream has delivered a
message. With ``sync``, the triggers that arrive before the first message of another stream wait for
it (up to 2 s of them: a DDS reader that matched its writer a moment late receives that writer's
first messages resent, tens of ms after the others), then meet their partners as below.

Pairing. By default each trigger message meets the latest message of the other streams that
has arrived: what a subscriber sees, right for streams stamped by different clocks (the dVRK's
joint states and the HEX10 come from different processes). ``sync=True`` pairs by stamp, for
streams stamped on one clock (a simulated robot, a bench that samples every channel at the same
instant): a trigger waits until each other stream has delivered a message stamped at or after
its own, then meets, of each, the latest stamped at or before it, so a message that arrives
late (a lost datagram resent, a busy transport) still meets its own trigger. A trigger waits
for at most ``max_wait_s`` of later triggers (0.1 s: 100 at 1 kHz; a partner resent or held up
by a busy transport is late by tens of ms), then is answered with what there is
(counted in :attr:`ForceNode.unpaired`).

Outputs per answer (:func:`output_topics`, under ``/{arm}/tool_force/``; header stamp = the
stamp of the trigger message answered):

``base``   geometry_msgs/WrenchStamped, the external force ON the tool in the PSM base frame
           (``frame_id`` ``{arm}_base``), N; torque zero (not estimated).
``hex10``  the same force in the HEX10 frame (``frame_id`` ``hex10``).
``std``    geometry_msgs/Vector3Stamped, per-axis std of the raw estimate, N, HEX10 frame (only
           for a network that predicts its variance,
           :mod:`psmforce.estimators.networks.uncertainty`).
``flags``  std_msgs/UInt32: the bits of :class:`psmforce.estimators.runtime.streaming.Flags` (bits
0-8), and the
           node's own :data:`TARING` (bit 16) and :data:`STALE` (bit 17). Unstamped (kept for
           subscribers written against it): pair it by order, or read ``status``.
``status`` diagnostic_msgs/DiagnosticArray, the same flags stamped with the answered stamp: one
           status, ``name`` ``psmforce/{arm}/tool_force``, ``level`` OK (no flag), WARN (the
           estimate stands but is qualified: warming up, overload, time step back, gap,
           extrapolation, taring, stale) or ERROR (no usable estimate: invalid input, held,
           reset, implausible; :data:`ERROR_FLAGS`), ``message`` the flag names joined by
           ``|``, ``values`` ``flags`` (the bits in decimal) and ``stamp_ns``.

Tare. The estimate's offset in free space is removed by a tare: :meth:`ForceNode.request_tare`
(``serve``: any message on ``/{arm}/tool_force/tare``, std_msgs/Empty, or ``--tare-on-start``)
averages the next ``tare_s`` seconds of answers that are neither warming up nor held (flagged
``TARING`` meanwhile; the arm must be still and touch nothing), then subtracts that mean (HEX10
frame) from every later force, rotated into the base frame for ``base``. ``STALE``: a
non-trigger stream has delivered nothing while more than ``stale_periods`` trigger messages
arrived (a stream stalled; the estimate uses its last values). Staleness is judged on the order
the node receives messages in (``serve``: by DDS source time; ``replay``: the bag's receive
order), never by comparing header stamps of different clocks: an arm whose clock runs 50 ms
behind the HEX10's is not stale, one that stops is, whatever its stamps say, and a transport
hiccup that delays every stream alike flags nothing. With ``sync`` the streams share one clock
(that is what pairing by stamp assumes), so there it is judged on that clock: a partner stamped
more than ``stale_periods`` input periods before the trigger it meets is stale.
"""

from __future__ import annotations

from collections import deque
from dataclasses import dataclass

import numpy as np

from psmforce.estimators.runtime.streaming import Flags, StreamingEstimator
from psmforce.io.bags.messages import (MessageError, SampleArray, sample_from_messages,
                                       stamp_ns)
from psmforce.io.bags.names import check_namespace
from psmforce.live import cdr

TARING = 1 << 16
"""Node flag: a tare is being collected; the force still carries the previous offset."""
STALE = 1 << 17
"""Node flag: an input stream's latest message is older than ``stale_periods``."""

INPUT_STREAMS = ("js", "jaw", "hex10")
OUTPUT_TYPES = {"base": "geometry_msgs/msg/WrenchStamped",
                "hex10": "geometry_msgs/msg/WrenchStamped",
                "std": "geometry_msgs/msg/Vector3Stamped", "flags": "std_msgs/msg/UInt32",
                "status": "diagnostic_msgs/msg/DiagnosticArray"}
"""The ROS 2 message type of each output (module docstring)."""
TARE_TYPE = "std_msgs/msg/Empty"


FLAG_NAMES = {**{int(f): f.name for f in Flags if f}, TARING: "TARING", STALE: "STALE"}
"""Each flag bit's name, as ``status`` gives them."""
ERROR_FLAGS = Flags.INVALID_INPUT | Flags.HELD | Flags.RESET | Flags.IMPLAUSIBLE
"""Flags that leave no usable estimate: ``status`` level ERROR (any other flag: WARN)."""


def status_of(flags: int) -> tuple[int, str]:
    """The DiagnosticStatus level (0 OK, 1 WARN, 2 ERROR) and message of ``flags``."""
    names = "|".join(name for bit, name in FLAG_NAMES.items() if flags & bit)
    return (2 if flags & ERROR_FLAGS else 1 if flags else 0), names


def output_topics(arm: str = "PSM1") -> dict[str, str]:
    """The topic of each output, and ``tare`` (the tare request, std_msgs/Empty)."""
    root = f"/{check_namespace(arm)}/tool_force"  # ROS 2's naming rules, one line if not
    return {name: f"{root}/{name}" for name in (*OUTPUT_TYPES, "tare")}


@dataclass(frozen=True)
class Answer:
    """One answer: the force for the trigger message stamped ``stamp_ns`` (module docstring)."""

    stamp_ns: int
    force_hex10: np.ndarray
    """(3,) N, HEX10 frame, tared."""
    force_base: np.ndarray
    """(3,) N, PSM base frame, tared."""
    std_hex10: np.ndarray | None
    flags: int


def check_sync_wait(max_wait_s: float) -> None:
    """Refuse a wait for a trigger's partners (module docstring, Pairing) that is not > 0 s."""
    if not max_wait_s > 0:
        raise ValueError(f"the wait for a trigger's partners must be > 0 s, got {max_wait_s!r}")


class ForceNode:
    """Latest of each stream -> one estimator step per trigger message (module docstring).

    ``estimator``: built with a PSM model (``psm=psmforce.robot.PSM()``) for the base frame.
    ``arm``: namespace of the output topics and of the base frame's id. ``sync``: pair by
    stamp (module docstring, Pairing).
    """

    def __init__(self, estimator: StreamingEstimator, *, arm: str = "PSM1",
                 trigger: str = "hex10", tare_s: float = 0.5, stale_periods: float = 10.0,
                 sync: bool = False, max_wait_s: float = 0.1):
        if trigger not in INPUT_STREAMS:
            raise ValueError(f"trigger must be one of {INPUT_STREAMS}, got {trigger!r}")
        if not tare_s > 0:
            raise ValueError(f"tare_s must be > 0 s, got {tare_s!r}")
        check_sync_wait(max_wait_s)
        self.estimator = estimator
        try:
            self._sample = SampleArray(estimator.columns)
        except MessageError:  # the messages lack a column: every sample is flagged, as a mapping
            self._sample = None
        self._status_body: dict[int, bytes] = {}
        self.trigger = trigger
        self.topics = output_topics(arm)
        self.base_frame_id = f"{arm.strip('/')}_base"
        self._status_name = f"psmforce/{arm.strip('/')}/tool_force"
        self.latest: dict[str, object] = dict.fromkeys(INPUT_STREAMS)
        self._silent = {s: 0 for s in INPUT_STREAMS if s != trigger}
        """Trigger messages received since each other stream's latest message."""
        self._stale_after = stale_periods
        self._stale_ns = stale_periods / estimator.input_rate_hz * 1e9
        self._tare_n = max(1, round(tare_s * estimator.input_rate_hz))
        self.offset = np.zeros(3)
        """The tare subtracted from every force (N, HEX10 frame)."""
        self._tare_left = 0
        self._tare_sum = np.zeros(3)
        self.answers = 0
        self.unpaired = 0
        """With ``sync``: answers given before every partner had arrived (module docstring)."""
        self.sync = sync
        self._max_pending = max(1, round(max_wait_s * estimator.input_rate_hz))
        self._pending: deque = deque()
        # the partners not yet passed by a released trigger: a few normally; up to 2 s of
        # messages when the trigger stream lags behind the others (a busy transport)
        self._startup_pending = max(4 * self._max_pending, round(2 * estimator.input_rate_hz))
        self._history = {s: deque(maxlen=self._startup_pending)
                         for s in INPUT_STREAMS
                         if s != trigger}

    def request_tare(self) -> None:
        """Start a tare: average the next usable answers (module docstring)."""
        self._tare_left = self._tare_n
        self._tare_sum[:] = 0.0

    @property
    def taring(self) -> bool:
        return self._tare_left > 0

    def update(self, stream: str, message) -> list[Answer]:
        """Take the newest ``message`` of ``stream`` (:data:`INPUT_STREAMS`), in the order
        received; the answers it releases: the trigger's once every stream has delivered (with
        ``sync``: the triggers whose partners are known, module docstring), else none."""
        if stream != self.trigger:
            self._silent[stream] = 0
            self.latest[stream] = message
            if self.sync:
                self._history[stream].append((stamp_ns(message) or 0, message))
                return self._release(False)
            return []
        if not self.sync:
            if any(m is None for s, m in self.latest.items() if s != stream):
                return []
            self.latest[stream] = message
            return [self._answer(message, self._stale())]
        self._pending.append((message, self._stale()))
        return self._release(False)

    def _stale(self) -> bool:
        """One more trigger message received: has another stream been silent too long?"""
        for name in self._silent:
            self._silent[name] += 1
        return max(self._silent.values()) > self._stale_after

    def flush(self) -> list[Answer]:
        """With ``sync``: answer every trigger still waiting, with the partners there are."""
        return self._release(True) if self.sync else []

    def _release(self, force: bool) -> list[Answer]:
        answers = []
        while self._pending:
            stamp = stamp_ns(self._pending[0][0]) or 0
            if not all(self._history.values()):  # a stream has delivered nothing yet
                if not (force or len(self._pending) > self._startup_pending):
                    break
                self._pending.popleft()  # no answer without it (module docstring)
                continue
            ready = all(h[-1][0] >= stamp for h in self._history.values())
            if not (ready or force or len(self._pending) > self._max_pending):
                break
            trigger, _ = self._pending.popleft()
            self.unpaired += not ready
            for name, history in self._history.items():  # the latest at or before the stamp
                while len(history) > 1 and history[1][0] <= stamp:
                    history.popleft()  # passed: later triggers are stamped later
                self.latest[name] = history[0][1]
            stale = any(stamp - h[0][0] > self._stale_ns for h in self._history.values())
            answers.append(self._answer(trigger, stale))
        return answers

    def _answer(self, message, stale: bool) -> Answer:
        self.latest[self.trigger] = message
        stamp = stamp_ns(message)
        flags = STALE if stale else 0
        latest = self.latest
        try:
            if self._sample is None:
                sample = sample_from_messages(latest["js"], latest["jaw"], latest["hex10"],
                                              time_s=stamp * 1e-9 if stamp else None)
            else:
                sample = self._sample(latest["js"], latest["jaw"], latest["hex10"])
        except (MessageError, AttributeError, TypeError, ValueError):
            sample = {}  # refused by the estimator: INVALID_INPUT, the last estimate held
        # no stamp: time None, which the estimator refuses for an array (INVALID_INPUT)
        out = self.estimator.step(sample, time=stamp * 1e-9 if stamp else None, base_frame=True)
        flags |= out.flags
        raw = out.force_hex10
        if self._tare_left and not out.flags & (Flags.WARMING_UP | Flags.HELD):
            self._tare_sum += raw
            self._tare_left -= 1
            if not self._tare_left:
                self.offset = self._tare_sum / self._tare_n
        if self._tare_left:
            flags |= TARING
        force, base = raw, out.force_base
        # untared (offset zero) the estimate stands as it is: subtracting zero changes nothing
        # and the rotation costs a forward kinematics (Python floats: a cheaper test than
        # ndarray.any() on three values, once per message)
        if any(self.offset.tolist()):
            force = raw - self.offset
            base = base - self.estimator.base_rotation() @ self.offset
        self.answers += 1
        return Answer(int(stamp or 0), force, base, out.std_hex10, int(flags))

    def encode(self, answer: Answer) -> dict[str, bytes]:
        """The CDR bytes of each output of ``answer`` (:mod:`psmforce.live.cdr`), by output
        name (``std`` only with a std)."""
        stamp = answer.stamp_ns
        # the vectors as Python floats, one tolist() each: the encoder converts what it is given
        # value by value, and numpy's scalars are slower to make and to convert
        out = {"base": cdr.wrench_stamped(stamp, self.base_frame_id, answer.force_base.tolist()),
               "hex10": cdr.wrench_stamped(stamp, "hex10", answer.force_hex10.tolist()),
               "flags": cdr.uint32(answer.flags), "status": self._status(stamp, answer.flags)}
        if answer.std_hex10 is not None:
            out["std"] = cdr.vector3_stamped(stamp, "hex10", answer.std_hex10.tolist())
        return out

    def _status(self, stamp: int, flags: int) -> bytes:
        """``status``'s bytes: its one status depends on the flags alone but for the stamp, in
        the header and in the last value, so the rest is encoded once per flags value."""
        body = self._status_body.get(flags)
        if body is None:
            level, message = status_of(flags)
            # the last value empty: its length (1, the NUL alone) and NUL are the last 5 bytes
            body = self._status_body[flags] = cdr.diagnostic_array(0, "hex10", [(
                level, self._status_name, message, self.base_frame_id.removesuffix("_base"),
                [("flags", str(flags)), ("stamp_ns", "")])])[:-5]
        return bytes(cdr.restamp(body, stamp) + cdr.string_tail(str(stamp)))
