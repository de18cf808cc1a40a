"""``python -m reports [--check]``: rebuild every rendered page from its JSON (:mod:`reports.render`)."""

import sys

from reports.render import main

sys.exit(main())
