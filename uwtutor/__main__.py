"""``python -m uwtutor``: the same command as ``uwtutor`` (for example ``python -m uwtutor exercises DIR``)."""

import sys

from .exercises.cli import main

if __name__ == "__main__":
    sys.exit(main())
