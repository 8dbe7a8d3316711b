"""``python -m porepipe``: the ``porepipe`` command, for an environment whose scripts folder is not on PATH."""

import sys

from porepipe.cli import main

sys.exit(main())
