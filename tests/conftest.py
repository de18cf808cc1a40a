"""Fixtures shared by the CLI failure tests, and the thread budget of a parallel run."""

import os

import pytest
import torch

import psmforce.estimators.training.train

# The suite runs in pytest-xdist workers (pyproject.toml's addopts, one per core): each worker
# gets its share of the cores, and so do the commands it starts, so that torch's pools (sized to
# every core) do not oversubscribe them.
_WORKERS = int(os.environ.get("PYTEST_XDIST_WORKER_COUNT", "1"))
if _WORKERS > 1:
    _THREADS = max(1, (os.cpu_count() or 1) // _WORKERS)
    os.environ.setdefault("OMP_NUM_THREADS", str(_THREADS))
    torch.set_num_threads(_THREADS)


@pytest.fixture
def no_training(monkeypatch):
    """Any check that fires only after loading the data would reach this and fail the test."""
    def refuse(*args, **kwargs):
        raise AssertionError("the bad option was not found before the expensive work")
    monkeypatch.setattr(psmforce.estimators.training.train, "load_dataset", refuse)


@pytest.fixture
def cli_error(capsys):
    """``cli_error(command)``: the one stderr line of a failed ``psmforce command`` (asserted to
    be exactly one line in the CLI's error format)."""
    def read(command: str) -> str:
        lines = capsys.readouterr().err.strip().splitlines()
        assert len(lines) == 1 and lines[0].startswith(f"psmforce {command}: error: "), lines
        return lines[0]
    return read
