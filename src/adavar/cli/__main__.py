"""``python -m adavar.cli``."""

import sys

from adavar.cli.main import main

sys.exit(main())
