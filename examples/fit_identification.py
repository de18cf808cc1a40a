"""Fit the two identification models: arm dynamics on real dVRK data, the internal-force prior on
the simulated bench. Run from the repository root: python examples/fit_identification.py [OUT]"""
import sys
from pathlib import Path

from psmforce.identification import InternalForcePrior, fit_dynamics_cli, fit_prior_cli
from psmforce.io.recording import read_recording
from psmforce.sim import simulate

out = Path(sys.argv[1] if len(sys.argv) > 1 else "out/example_identification")
out.mkdir(parents=True, exist_ok=True)

wpi = Path("../shared/data/wpi_psm")  # real dVRK Classic PSM recordings (Wang et al. 2019)
if wpi.exists():
    arm = fit_dynamics_cli(wpi / "one_results.csv", wpi / "two_results.csv", "wpi", None,
                           out / "arm.json")
    print("test relative torque error per joint (%):",
          [round(e, 1) for e in arm["test_relative_error_percent"]])

simulate("automated", scale=0.02, seed=0, out=out / "bench")   # or a folder of your recordings
fit_prior_cli(out / "bench", out / "prior.json")                # fitted on free-space trials
prior = InternalForcePrior.load(out / "prior.json")
frame = read_recording(sorted((out / "bench/test/Free").glob("*.csv"))[0])
print("internal wrench the HEX10 reads at t=0 [fx fy fz N, tx ty tz Nm]:",
      prior.predict(frame)[0].round(3))
