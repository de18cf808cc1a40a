"""Bad input against the simulated bench (`simulate`)."""

from __future__ import annotations

from tests.robustness.harness import Attempt, Case, out_option, registrar


def cases() -> list[Case]:
    """The cases of this artefact, in a fixed order."""
    found: list[Case] = []
    case = registrar(found)


    # --- simulate ----------------------------------------------------------------------------
    simulate_option = out_option(found, "simulate", "sim", "psmforce.sim.protocols.automated")

    simulate_option("--scale 1e6", ["--scale", "1e6"], ("--scale",))
    simulate_option("--scale 0", ["--scale", "0"], ("--scale", "scale"))
    simulate_option("--scale -1", ["--scale", "-1"], ("--scale", "scale"))
    simulate_option("--scale nan", ["--scale", "nan"], ("--scale", "scale"))
    simulate_option("--scale inf", ["--scale", "inf"], ("--scale", "scale"))
    simulate_option("--scale abc", ["--scale", "abc"], ("--scale",))
    simulate_option("--seed 1e23", ["--seed", "1e23"], ("--seed",))
    simulate_option("--seed -1", ["--seed", "-1"], ("--seed", "seed"))
    simulate_option("--tool-spread without --tool-seed", ["--tool-spread", "2"],
                    ("--tool-spread",))
    simulate_option("--tool-spread -1", ["--tool-seed", "1", "--tool-spread", "-1"],
                    ("--tool-spread", "tool_spread"))
    simulate_option("--tool-spread nan", ["--tool-seed", "1", "--tool-spread", "nan"],
                    ("--tool-spread", "tool_spread"))
    simulate_option("--protocol surgery", ["--protocol", "surgery"], ("--protocol",))
    simulate_option("--json into a missing folder", ["--json", "/nonexistent/dir/s.json"],
                    ("--json",))
    simulate_option("--out holds a dataset", [], ("--out", "out"),
                    prepare_out=lambda out: (out.mkdir(), (out / "metadata.json").write_text(
                        '{"trials": []}')))
    simulate_option("--out is a file", [], ("--out", "out"),
                    prepare_out=lambda out: out.write_text(""))

    @case("cli simulate", "--out under a file")
    def _(s, d):
        (d / "blocker").write_text("")
        return Attempt(argv=["simulate", "--scale", "0.005", "--out", str(d / "blocker" / "b")],
                       names=(str(d / "blocker"),), guard="psmforce.sim.protocols.automated")
    return found
