"""``python -m labkit.grading ...``: the ``labkit grade`` command on its own."""

import sys

from .command import main

if __name__ == "__main__":
    sys.exit(main())
