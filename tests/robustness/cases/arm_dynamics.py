"""Bad input against arm dynamics fits and wrenches from joint torques (`fit-dynamics`, `wrench`)."""

from __future__ import annotations

import json
import shutil

import numpy as np

from tests.robustness.harness import Attempt, Case, _resealed, registrar, trial


def cases() -> list[Case]:
    """The cases of this artefact, in a fixed order."""
    found: list[Case] = []
    case = registrar(found)


    # --- fit-dynamics and wrench -------------------------------------------------------------
    @case("cli fit-dynamics", "default --format csv without --data")
    def _(s, d):
        return Attempt(argv=["fit-dynamics", "--model-out", str(d / "arm.json")],
                       names=("--data",))

    @case("cli fit-dynamics", "--format wpi without --train")
    def _(s, d):
        return Attempt(argv=["fit-dynamics", "--format", "wpi", "--model-out",
                             str(d / "arm.json")], names=("--train",))

    @case("cli fit-dynamics", "--data missing")
    def _(s, d):
        return Attempt(argv=["fit-dynamics", "--data", str(d / "none"), "--model-out",
                             str(d / "arm.json")], names=(str(d / "none"),))

    @case("cli fit-dynamics", "--data a text file")
    def _(s, d):
        (d / "free.csv").write_text("hello\n")
        return Attempt(argv=["fit-dynamics", "--data", str(d / "free.csv"), "--model-out",
                             str(d / "arm.json")], names=(str(d / "free.csv"),))

    @case("cli fit-dynamics", "--gravity nan nan nan")
    def _(s, d):
        return Attempt(argv=["fit-dynamics", "--data", str(s.bench), "--gravity", "nan", "nan",
                             "nan", "--model-out", str(d / "arm.json")],
                       names=("--gravity", "gravity"),
                       guard="psmforce.identification.recordings.fit_conditioned")

    @case("cli fit-dynamics", "--format wpi on 3000 x 21 random numbers")
    def _(s, d):
        noise = np.random.default_rng(0).standard_normal((3000, 21))
        for name in ("train.csv", "test.csv"):
            np.savetxt(d / name, noise, delimiter=",")
        return Attempt(argv=["fit-dynamics", "--format", "wpi", "--train", str(d / "train.csv"),
                             "--test", str(d / "test.csv"), "--model-out", str(d / "arm.json")],
                       names=("--accept-poor-fit", str(d / "train.csv")))

    def dynamics_file(name, write):
        @case("cli wrench", f"--dynamics {name}")
        def _(s, d):
            path = d / "arm.json"
            write(s, path)
            return Attempt(argv=["wrench", str(trial(s.bench)), "--dynamics", str(path),
                                 "--out", str(d / "w.csv")], names=(str(path),))

    @case("cli wrench", "--out is a folder")
    def _(s, d):
        return Attempt(argv=["wrench", str(trial(s.bench)), "--dynamics", str(s.arm),
                             "--out", str(d)], names=("--out",))

    @case("cli wrench", "--out in a missing folder")
    def _(s, d):
        return Attempt(argv=["wrench", str(trial(s.bench)), "--dynamics", str(s.arm),
                             "--out", str(d / "no" / "w.csv")], names=("--out",))

    @case("cli wrench", "--dynamics with a NaN parameter")
    def _(s, d):
        doc = json.loads(s.arm.read_text())
        doc["gravity_mps2"][0] = float("nan")
        path = d / "arm.json"
        path.write_text(json.dumps(_resealed(doc)))  # resealed: the NaN check must refuse it
        return Attempt(argv=["wrench", str(trial(s.bench)), "--dynamics", str(path),
                             "--out", str(d / "w.csv")], names=(str(path),))

    dynamics_file("missing", lambda s, path: None)
    dynamics_file("zero-byte", lambda s, path: path.write_text(""))
    dynamics_file("not JSON", lambda s, path: path.write_text("arm: yes\n"))
    dynamics_file("a list", lambda s, path: path.write_text("[1, 2]"))
    dynamics_file("a prior JSON", lambda s, path: shutil.copy(s.prior, path))
    return found
