"""An instrument's cable transmission from motor to jaw: the real EndoWrist recordings' reader
(:mod:`.recording`), the identified model (:mod:`.model`, ``CableTransmission``) and its
hysteresis (:mod:`.hysteresis`). docs/identification.md, section 4."""
