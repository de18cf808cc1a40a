"""What the studies run, kept out of the runtime wings: ``psmforce reproduce``
(:mod:`.reproduce`, its plan :mod:`.plan` and its cache of tasks :mod:`.task_cache`), the bench's
calibration against real data (:mod:`.bench_calibration`), prior recovery
(:mod:`.prior_recovery`), the cable-law figures against the real EndoWrist
(:mod:`.cable_law_figures`), the transmission networks (:mod:`.transmission_networks`), the
stream fuzzer (:mod:`.stream_fuzzer`) and the JSON writing and resumable steps the scripts
share (:mod:`.report`)."""
