"""Tool-tip force estimators over HEX10 and dVRK joint inputs.

The hybrid estimator (internal-force prior + causal transformer on the residual) and the seed
paper's baselines (transformer, FCN, inverse-dynamics LSTM, and MultiRocket-Hydra) share one data
pipeline (:mod:`hybrid.data`), one training loop (:mod:`hybrid.train`) and one evaluation
(:mod:`hybrid.evaluate`). What differs between models is one entry each in the recipe table
(:mod:`hybrid.recipes`), and what a model provides is one of the protocols of
:mod:`hybrid.contract`; a trained model is one record (:class:`hybrid.checkpoint.TrainedModel`).
:class:`StreamingEstimator` runs a trained streamable model (the hybrid) one sample at a time.
"""

from hybrid.streaming import StreamingEstimator

__all__ = ["StreamingEstimator"]
