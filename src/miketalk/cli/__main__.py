"""``python -m miketalk.cli``: the command line."""

import sys

from miketalk.cli.main import main

sys.exit(main())
