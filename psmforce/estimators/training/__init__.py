"""Training: the loop with early stopping and its resumable state (:mod:`.train`,
:mod:`.resume`), calibration to another instrument (:mod:`.calibrate`) and the record of a
trained model (:mod:`.checkpoint`)."""
