"""Every Python example of the README runs as written on a clean clone: in order, in one
process, from an empty folder (so data it does not ship is absent and the example skips it), and
writes only into the folder it names (``out/readme``)."""

from __future__ import annotations

import pytest

import os
import re
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]


def readme_examples() -> list[str]:
    return re.findall(r"```python\n(.*?)```", (ROOT / "README.md").read_text(), flags=re.S)


def test_the_readme_has_its_examples():
    assert len(readme_examples()) >= 4


@pytest.mark.slow
@pytest.mark.e2e
def test_readme_examples_run_as_written_and_write_only_into_out_readme(tmp_path):
    script = "\n\n".join(readme_examples())
    env = {**os.environ, "OMP_NUM_THREADS": "1", "MPLBACKEND": "Agg"}
    run = subprocess.run([sys.executable, "-c", script], cwd=tmp_path, env=env, check=False,
                         capture_output=True, text=True, timeout=900)
    assert run.returncode == 0, run.stderr[-3000:]
    assert sorted(p.name for p in tmp_path.iterdir()) == ["out"]
    assert sorted(p.name for p in (tmp_path / "out").iterdir()) == ["readme"]
    written = {p.name for p in (tmp_path / "out" / "readme").iterdir()}
    assert {"bench", "prior.json", "hybrid.pt", "wide.pt"} <= written
    last = run.stdout.strip().splitlines()[-1]  # the streamed estimate: a finite force, N
    assert re.match(r"\[\s*-?\d+\.\d+\s+-?\d+\.\d+\s+-?\d+\.\d+\s*\]", last), last
