"""The models: the hybrid's causal transformer (:mod:`.causal`), the paper's baselines
(:mod:`.baselines`, :mod:`.rocket`), per-axis uncertainty (:mod:`.uncertainty`), what a model
provides (:mod:`.contract`) and one entry per model in the recipe table (:mod:`.recipes`)."""
