"""Bad input against gates that speak: every fit prints its verdict."""

from __future__ import annotations

from tests.robustness.harness import Attempt, Case, _register, registrar


def cases() -> list[Case]:
    """The cases of this artefact, in a fixed order."""
    found: list[Case] = []
    case = registrar(found)


    # --- gates that speak ----------------------------------------------------------------------
    @case("cli fit-prior: gate", "the verdict is printed on the console", "HANDLED")
    def _(s, d):
        out = d / "p.json"

        def check(stdout):
            verdict = [ln for ln in stdout.splitlines() if ln.startswith("verdict: ")]
            return bool(verdict) and out.exists(), f"{verdict}"
        return Attempt(argv=["fit-prior", "--data", str(s.bench), "--out", str(out),
                             "--accept-poor-fit"], check=check)

    # --- gates that speak: every fit's verdict on the console -----------------------------
    @_register(found, "cli fit-dynamics: gate", "the verdict is printed on the console",
               "HANDLED")
    def _(s, d):
        out = d / "arm.json"

        def check(stdout):
            verdict = [ln for ln in stdout.splitlines() if ln.startswith("verdict: ")]
            return bool(verdict) and out.exists(), f"{verdict}"
        return Attempt(argv=["fit-dynamics", "--data", str(s.bench), "--model-out", str(out),
                             "--accept-poor-fit"], check=check)
    return found
