"""Bad input against `reproduce` and `demo` runs: bad arguments found before any folder or work, repeated seeds."""

from __future__ import annotations

import torch

from tests.robustness.harness import Attempt, Case, _register, out_option, registrar


def cases() -> list[Case]:
    """The cases of this artefact, in a fixed order."""
    found: list[Case] = []
    case = registrar(found)


    # --- reproduce and demo: bad arguments found before any folder or work --------------------
    reproduce_option = out_option(found, "reproduce", "run", "psmforce.experiments.reproduce.run_grid")

    reproduce_option("--scale 0", ["--scale", "0"], ("--scale",))
    reproduce_option("--scale -1", ["--scale", "-1"], ("--scale",))
    reproduce_option("--scale nan", ["--scale", "nan"], ("--scale",))
    reproduce_option("--scale 1e6", ["--scale", "1e6"], ("--scale",))
    reproduce_option("--seeds -1", ["--seeds", "-1"], ("--seeds",))
    reproduce_option("--seeds 1e23", ["--seeds", "1e23"], ("--seeds",))
    reproduce_option("--budget huge", ["--budget", "huge"], ("--budget",))
    reproduce_option("--models svm", ["--models", "svm"], ("--models",))
    if not torch.cuda.is_available():
        reproduce_option("--device cuda without CUDA", ["--device", "cuda"], ("--device",))
    reproduce_option("--out is a file", [], ("--out",),
                     prepare_out=lambda out: out.write_text(""))

    @case("cli reproduce", "--out under a file")
    def _(s, d):
        (d / "blocker").write_text("")
        return Attempt(argv=["reproduce", "--out", str(d / "blocker" / "run")],
                       names=("--out",), guard="psmforce.experiments.reproduce.run_grid")

    for name, kwargs in (("scale=-1", {"scale": -1.0}), ("scale=nan", {"scale": float("nan")}),
                         ("seeds=[-1]", {"seeds": [-1]})):
        def reproduce_api(s, d, kwargs=kwargs):
            from psmforce.experiments.reproduce import reproduce
            return Attempt(call=lambda: reproduce(d / "run", **kwargs),
                           names=tuple(kwargs), guard="psmforce.experiments.reproduce.run_grid")
        found.append(Case("api reproduce", name, "REJECTED", reproduce_api))

    @case("cli demo", "--out not empty")
    def _(s, d):
        (d / "demo").mkdir()
        (d / "demo" / "notes.txt").write_text("mine\n")
        return Attempt(argv=["demo", "--out", str(d / "demo")], names=("--out",),
                       guard="psmforce.sim.simulate")

    # --- runs refuse repeated seeds -------------------------------------------------------------
    for seeds in (["0", "0"], ["1", "2", "1"], ["3", "3", "3"]):
        @case("cli reproduce: seeds", f"--seeds {' '.join(seeds)}")
        def _(s, d, seeds=seeds):
            return Attempt(argv=["reproduce", "--out", str(d / "run"), "--seeds", *seeds],
                           names=("--seeds",), guard="psmforce.experiments.reproduce.run_grid")

    # --- repeated seeds from Python, before any work ----------------------------------------
    for seeds in ((1, 1), (2, 3, 2)):
        @_register(found, "api reproduce: seeds", f"seeds={seeds}")
        def _(s, d, seeds=seeds):
            from psmforce.experiments.reproduce import reproduce
            return Attempt(call=lambda: reproduce(d / "run", seeds=seeds), names=("seeds",),
                           guard="psmforce.experiments.reproduce.run_grid")
    return found
