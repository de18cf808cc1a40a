"""The pages' renderers: every figure the README and ``docs/`` show, rendered from a committed
JSON. ``python -m reports`` rebuilds them all (:mod:`reports.render`); one module of render
functions per page."""
