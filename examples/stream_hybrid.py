"""Train the hybrid estimator briefly and run it one sample at a time, as a haptic loop would.
Needs the bench and prior written by examples/fit_identification.py.
Run from the repository root: python examples/stream_hybrid.py [OUT]"""
import sys
from pathlib import Path

from psmforce.estimators import StreamingEstimator
from psmforce.estimators.training.train import train
from psmforce.robot import PSM
from psmforce.io.recording import read_recording

out = Path(sys.argv[1] if len(sys.argv) > 1 else "out/example_identification")
train(out / "bench", "hybrid", out / "hybrid.pt", prior=out / "prior.json", epochs=3)
estimator = StreamingEstimator.from_checkpoint(out / "hybrid.pt", post_filter="lowpass", psm=PSM())
frame = read_recording(sorted((out / "bench/test/Traction").glob("*.csv"))[0])
for sample in frame.to_dict("records")[:300]:          # one dict per 10 ms sample
    estimate = estimator.step(sample, base_frame=True)
print("force on the tool [N], HEX10 frame:", estimate.force_hex10.round(2),
      " base frame:", estimate.force_base.round(2), " flags:", estimate.flags)
