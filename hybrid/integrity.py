"""The integrity envelope (:mod:`psm_model.integrity`, where it lives so that the identified
models below the estimators can use it too), under the name the estimators' artefacts use:
checkpoints (:mod:`hybrid.checkpoint`), exports (:mod:`hybrid.export`) and cached task results
(:mod:`hybrid.grid`). docs/integrity.md says what each artefact carries and what is refused.
"""

from psm_model import integrity as _envelope

DIGEST = _envelope.DIGEST
IntegrityError = _envelope.IntegrityError
canonical = _envelope.canonical
sha256_bytes = _envelope.sha256_bytes
seal = _envelope.seal
verify = _envelope.verify
check_version = _envelope.check_version
