"""Tool-tip force estimators over HEX10 and dVRK joint inputs.

The hybrid estimator (internal-force prior + causal transformer on the residual) and the seed
paper's baselines (transformer, FCN, inverse-dynamics LSTM, and MultiRocket-Hydra) share one data
pipeline (:mod:`psmforce.estimators.data.dataset`), one training loop
(:mod:`psmforce.estimators.training.train`) and one evaluation
(:mod:`psmforce.estimators.evaluation.evaluate`). What differs between models is one entry each in
the recipe table (:mod:`psmforce.estimators.networks.recipes`), and what a model provides is one of
the protocols of :mod:`psmforce.estimators.networks.contract`; a trained model is one record
(:class:`psmforce.estimators.training.checkpoint.TrainedModel`). :class:`StreamingEstimator` runs a
trained streamable model (the hybrid) one sample at a time.
"""

from psmforce.estimators.runtime.streaming import StreamingEstimator

__all__ = ["StreamingEstimator"]
