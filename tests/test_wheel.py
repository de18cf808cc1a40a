import pytest
"""The package installs as one import package, ``psmforce``: build the wheel, check that it holds
no other top-level name, install it into a fresh virtual environment
outside the repository, and run the library from there (the URDF must come from the wheel)."""
import os
import shutil
import subprocess
import sys
import sysconfig
import textwrap
import venv
import zipfile
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]

SCRIPT = textwrap.dedent("""
    import sys
    from pathlib import Path

    import psmforce
    venv = Path(sys.prefix).resolve()
    assert venv in Path(psmforce.__file__).resolve().parents, (psmforce.__file__, venv)

    import numpy as np
    from psmforce.estimators import StreamingEstimator
    from psmforce.estimators.training.train import TrainConfig, train
    from psmforce.robot import PSM
    from psmforce.identification import fit_prior_cli
    from psmforce.io.recording import read_recording
    from psmforce.sim import simulate

    psm = PSM()
    assert venv in Path(str(psm.urdf_path)).resolve().parents, psm.urdf_path
    assert psm.forward_kinematics(np.zeros(6)).shape == (4, 4)
    simulate("automated", scale=0.01, seed=0, out="bench")
    assert fit_prior_cli("bench", "prior.json")["converged"]
    train("bench", "hybrid", "hybrid.pt", prior="prior.json", epochs=1,
          train_config=TrainConfig(max_batches_per_epoch=2, max_val_batches=1, progress=False))
    estimator = StreamingEstimator.from_checkpoint("hybrid.pt", psm=psm)
    recording = next(Path("bench/test/Traction").glob("*.csv"))
    for sample in read_recording(recording).head(20).to_dict("records"):
        estimate = estimator.step(sample)
    print("streamed", estimate)
""")


def wheel_top_level(wheel: Path) -> set[str]:
    """The import names a wheel installs: the first part of every file's path but its
    ``.dist-info`` folder (a module at the top level counts by its stem)."""
    with zipfile.ZipFile(wheel) as archive:
        names = archive.namelist()
    return {Path(n).parts[0].removesuffix(".py") for n in names
            if not Path(n).parts[0].endswith((".dist-info", ".data"))}


def test_the_top_level_check_sees_a_second_package(tmp_path):
    """The check can fail: a wheel that also installs ``hybrid/`` and a loose module."""
    wheel = tmp_path / "x-1-py3-none-any.whl"
    with zipfile.ZipFile(wheel, "w") as archive:
        for name in ("psmforce/__init__.py", "hybrid/__init__.py", "loose.py",
                     "x-1.dist-info/RECORD"):
            archive.writestr(name, "")
    assert wheel_top_level(wheel) == {"psmforce", "hybrid", "loose"}


def _site_packages_line() -> str:
    """A .pth line giving the new environment this test's own dependencies (numpy, torch,
    pinocchio...) without installing them: ``--system-site-packages`` exposes the base
    interpreter's, which is not where they are when the tests run from a virtual environment.
    ``site.addsitedir`` runs that folder's .pth files too (pinocchio's cmeel path needs them);
    it appends, so the new environment's own site-packages, holding the wheel, comes first."""
    dirs = {sysconfig.get_paths()["purelib"], sysconfig.get_paths()["platlib"]}
    return "import site; " + "; ".join(f"site.addsitedir({d!r})" for d in sorted(dirs)) + "\n"


@pytest.mark.slow
@pytest.mark.e2e
def test_wheel_installs_and_runs_outside_the_repository(tmp_path):
    # build from a copy, so no build/ or *.egg-info left in the repository (and none reused)
    source = tmp_path / "source"
    ignore = shutil.ignore_patterns("__pycache__", "*.egg-info", "*.pyc")
    shutil.copytree(REPO / "psmforce", source / "psmforce", ignore=ignore)
    for name in ("pyproject.toml", "README.md"):
        shutil.copy2(REPO / name, source / name)
    wheels = tmp_path / "wheels"
    env = {k: v for k, v in os.environ.items() if k != "PYTHONPATH"}
    env.update(OMP_NUM_THREADS="1", PIP_NO_INDEX="1", PIP_DISABLE_PIP_VERSION_CHECK="1")
    subprocess.run([sys.executable, "-m", "pip", "wheel", "--no-deps", "--no-build-isolation",
                    "--wheel-dir", str(wheels), str(source)], check=True, env=env,
                   capture_output=True)
    (wheel,) = wheels.glob("psmforce-*.whl")
    assert wheel_top_level(wheel) == {"psmforce"}
    with zipfile.ZipFile(wheel) as archive:  # the shipped bench model travels with the wheel
        assert "psmforce/live/data/bench_hybrid.pt" in archive.namelist()

    prefix = tmp_path / "venv"
    venv.create(prefix, system_site_packages=True, with_pip=False)
    python = prefix / "bin" / "python"
    purelib = subprocess.run([str(python), "-c", "import sysconfig; "
                              "print(sysconfig.get_paths()['purelib'])"],
                             check=True, capture_output=True, text=True).stdout.strip()
    if sys.prefix != sys.base_prefix:
        (Path(purelib) / "_test_dependencies.pth").write_text(_site_packages_line())
    subprocess.run([str(python), "-m", "pip", "install", "--no-deps", str(wheel)], check=True,
                   env=env, capture_output=True)

    work = tmp_path / "work"
    work.mkdir()
    version = subprocess.run([str(prefix / "bin" / "psmforce"), "--version"], cwd=work, env=env,
                             check=True, capture_output=True, text=True).stdout.strip()
    from psmforce import __version__
    assert version == f"psmforce {__version__}"
    run = subprocess.run([str(python), "-c", SCRIPT], cwd=work, env=env, capture_output=True,
                         text=True)
    assert run.returncode == 0, run.stderr[-3000:]
    assert "streamed" in run.stdout
