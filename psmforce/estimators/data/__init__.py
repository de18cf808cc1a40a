"""What the estimators read: datasets of recordings and their splits (:mod:`.dataset`), each
model family's inputs (:mod:`.hybrid_inputs`, :mod:`.lstm_inputs`), physical bounds
(:mod:`.bounds`), sample rates (:mod:`.rates`) and the sanity checks before learning
(:mod:`.sanity`)."""
