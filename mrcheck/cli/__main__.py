"""``python -m mrcheck.cli``: the command line."""

import sys

from mrcheck.cli import main

sys.exit(main())
