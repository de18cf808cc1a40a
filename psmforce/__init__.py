"""The ``psmforce`` command line (``psmforce.cli``) and its demo.

``__version__`` is the package's version, the one place it is written: ``pyproject.toml`` reads it
from here (``[tool.setuptools.dynamic]``) and ``psmforce --version`` prints it.
"""

__version__ = "0.1.0"
