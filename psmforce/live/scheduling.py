"""The node's scheduling: Linux's SCHED_FIFO for ``psmforce serve --rt-priority``.

A normal process waits for the other processes' time slices, so on a busy host the node's tail
follows whatever else the cores run (docs/live.md, section 8). Under SCHED_FIFO it runs as soon
as a message wakes it, ahead of every normal process; it sleeps between messages, and the
kernel keeps a share of each second for normal processes (``sched_rt_runtime_us``), so it
cannot starve them. A node that polls instead of sleeping (``serve --busy-poll``) never gives
its core back, so it is refused under a real-time policy (:func:`check_busy_poll`).
"""

from __future__ import annotations

import os

RT_PRIORITIES = (1, 99)
"""The priorities of Linux's SCHED_FIFO."""


def run_realtime(priority: int | None) -> str:
    """Put the calling thread, and every thread it starts from now on (the DDS participant's
    receive threads, the estimator's), under Linux's SCHED_FIFO at ``priority`` (in
    :data:`RT_PRIORITIES`; ``None``: leave the scheduling as it is); returns it in words, for the
    report. Call it before the participant is created, so that its threads inherit it.
    A system that refuses it (no ``rtprio`` limit, no CAP_SYS_NICE) is one error line."""
    if priority is None:
        return "default (SCHED_OTHER)"
    if isinstance(priority, bool) or not isinstance(priority, int) \
            or not RT_PRIORITIES[0] <= priority <= RT_PRIORITIES[1]:
        raise ValueError(f"a real-time priority is an integer in {list(RT_PRIORITIES)}, "
                         f"got {priority!r}")
    if not hasattr(os, "sched_setscheduler"):
        raise ValueError("a real-time priority needs Linux's SCHED_FIFO, which this system "
                         "does not offer; leave the priority out")
    try:
        os.sched_setscheduler(0, os.SCHED_FIFO, os.sched_param(priority))
    except PermissionError as err:
        raise ValueError(f"the system refused real-time priority {priority} ({err.strerror}): "
                         "allow it with an rtprio limit (/etc/security/limits.conf, e.g. "
                         "'@realtime - rtprio 99', the user in that group) or CAP_SYS_NICE, "
                         "or leave the priority out") from None
    return f"SCHED_FIFO {priority}"


def check_busy_poll(realtime: bool | None = None) -> None:
    """Refuse a node that polls without sleeping in a real-time thread: it would keep every
    normal process off its core, the robot's and the subscribers' included. ``realtime``:
    whether the node will run under a real-time policy (None: the calling thread's now)."""
    if realtime is None:
        realtime = hasattr(os, "sched_getscheduler") and os.sched_getscheduler(0) in (
            os.SCHED_FIFO, os.SCHED_RR)
    if realtime:
        raise ValueError("busy polling in a real-time thread (--rt-priority) would keep every "
                         "normal process off the node's core: give one or the other")
