"""Evaluation as in the paper and as a haptic loop sees it: metrics (:mod:`.metrics`), scoring a
checkpoint on a dataset (:mod:`.evaluate`), tables (:mod:`.tables`) and plots (:mod:`.plots`)."""
