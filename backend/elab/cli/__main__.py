"""``python -m elab.cli``: the ``elab`` command."""

import sys

from elab.cli import main

if __name__ == "__main__":
    sys.exit(main())
