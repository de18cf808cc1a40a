"""psmforce/live/scheduling.py: SCHED_FIFO for the node, set and inherited or refused in one
line."""

import os
import subprocess
import sys

import pytest


def _env():
    return dict(os.environ, OMP_NUM_THREADS="1", PYTHONPATH=os.getcwd())


def test_a_real_time_priority_is_set_inherited_by_later_threads_or_refused_in_one_line(
        monkeypatch):
    """``serve --rt-priority``: SCHED_FIFO for the node's thread and the threads it starts after
    (the participant's); a system that refuses it is one line that says how to allow it. In a
    fresh process, so that this test's own process keeps its scheduling."""
    from psmforce.live.scheduling import run_realtime
    assert run_realtime(None) == "default (SCHED_OTHER)"
    with pytest.raises(ValueError, match="integer in"):
        run_realtime(0)
    probe = ("import os, threading; from psmforce.live.scheduling import run_realtime\n"
             "try:\n    print(run_realtime(10))\nexcept ValueError as err:\n"
             "    print('refused', err); raise SystemExit\n"
             "seen = []\nt = threading.Thread(target=lambda: seen.append("
             "os.sched_getscheduler(0) == os.SCHED_FIFO)); t.start(); t.join()\n"
             "print(os.sched_getscheduler(0) == os.SCHED_FIFO, seen[0])")
    out = subprocess.run([sys.executable, "-c", probe], env=_env(), capture_output=True,
                         text=True, timeout=60).stdout.splitlines()
    if out[0].startswith("refused"):
        assert "rtprio" in out[0]
    else:
        assert out == ["SCHED_FIFO 10", "True True"]
    def refuse(*_):
        raise PermissionError(1, "Operation not permitted")
    monkeypatch.setattr(os, "sched_setscheduler", refuse)
    with pytest.raises(ValueError, match=r"refused real-time priority 10 \(Operation not "
                                         r"permitted\): allow it with an rtprio limit"):
        run_realtime(10)



def test_busy_polling_is_refused_in_a_real_time_thread_and_allowed_otherwise(monkeypatch):
    """A node that never sleeps under SCHED_FIFO would starve every normal process on its core:
    refused when asked for (the command line, before the scheduling changes) and when the
    calling thread already is real-time (the library)."""
    from psmforce.live.scheduling import check_busy_poll
    with pytest.raises(ValueError, match=r"busy polling in a real-time thread \(--rt-priority\)"):
        check_busy_poll(True)
    check_busy_poll(False)
    check_busy_poll()                       # this test's process is a normal one
    monkeypatch.setattr(os, "sched_getscheduler", lambda pid: os.SCHED_FIFO)
    with pytest.raises(ValueError, match="give one or the other"):
        check_busy_poll()
