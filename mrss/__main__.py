"""Run the `mrss` command as `python -m mrss`."""

import sys

from mrss.cli import main

sys.exit(main())
