"""Issue 47, item 9: a small hybrid trained on the simulated bench ships with psmforce, marked as
such in its sealed provenance, so ``serve --sim`` answers with no training first; on a real
robot's topics it is refused unless the user says ``--bench-model``."""

from __future__ import annotations

import json
import subprocess
import sys

import pytest

from psmforce.estimators.training.checkpoint import load_checkpoint
from psmforce.live.bench_model import BENCH_MODEL_KEY, check_use, shipped_checkpoint


def test_the_shipped_checkpoint_is_a_sealed_streamable_bench_model():
    record = load_checkpoint(shipped_checkpoint())  # the envelope checked as any other
    assert record.recipe.streams and record.sample_rate_hz == pytest.approx(100.0)
    assert "simulated bench" in record.provenance[BENCH_MODEL_KEY]["trained_on"]
    assert shipped_checkpoint().stat().st_size < 2 << 20  # small enough to ship


def test_a_bench_model_runs_on_a_robot_only_when_the_user_says_so():
    marked = {BENCH_MODEL_KEY: {"trained_on": "the simulated bench"}}
    with pytest.raises(ValueError, match="simulated bench only.*--bench-model"):
        check_use(marked, "b.pt", simulated=False, allowed=False)
    check_use(marked, "b.pt", simulated=True, allowed=False)
    check_use(marked, "b.pt", simulated=False, allowed=True)
    check_use({"data": "lab"}, "own.pt", simulated=False, allowed=False)


def test_serve_without_a_checkpoint_needs_sim_and_the_bench_model_needs_consent(capsys):
    from psmforce.cli.main import main
    assert main(["serve", "--duration", "0.1"]) == 2
    assert "give a checkpoint" in capsys.readouterr().err
    assert main(["serve", str(shipped_checkpoint()), "--duration", "0.1"]) == 2
    assert "--bench-model" in capsys.readouterr().err


@pytest.mark.slow
@pytest.mark.e2e
def test_serve_sim_answers_with_the_shipped_model(tmp_path):
    """Stopped once it has answered (its first progress line with answers; it prints one a
    second), not after a fixed 6 s: SIGTERM ends serve with its report written, as
    tests/live/test_live_dds.py checks; --duration 60 is only a ceiling."""
    import signal
    import time
    report = tmp_path / "report.json"
    node = subprocess.Popen([sys.executable, "-m", "psmforce.cli.main", "serve", "--sim",
                             "--duration", "60", "--json", str(report)],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        deadline, line = time.monotonic() + 120, ""
        while "answers/s" not in line:
            line = node.stdout.readline()
            if not line or time.monotonic() > deadline:
                break  # ended or stalled: the checks below say how
        node.send_signal(signal.SIGTERM)
        _, err = node.communicate(timeout=120)
    finally:
        node.kill()
    assert node.returncode == 0, err[-2000:]
    assert json.loads(report.read_text())["answers_published"] > 0
