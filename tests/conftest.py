"""Fixtures shared by the CLI failure tests."""

import pytest

import psmforce.estimators.training.train


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
