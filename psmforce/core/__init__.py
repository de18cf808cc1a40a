"""What every layer uses and which imports nothing of the project: writes that are whole or
absent (:mod:`.files`), the integrity envelope of every artefact read back (:mod:`.integrity`)
and the filters the evaluation scores with (:mod:`.filters`)."""
