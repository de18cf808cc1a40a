"""Tool-tip force estimators over HEX10 and dVRK joint inputs.

The hybrid estimator (internal-force prior + causal transformer on the residual) and the seed
paper's baselines (transformer, FCN, inverse-dynamics LSTM) share one data pipeline
(:mod:`hybrid.data`), one training loop (:mod:`hybrid.train`) and one evaluation
(:mod:`hybrid.evaluate`). :class:`StreamingEstimator` runs a trained hybrid one sample at a time.
"""

from hybrid.streaming import StreamingEstimator

__all__ = ["StreamingEstimator"]
