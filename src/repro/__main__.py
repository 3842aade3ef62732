"""``python -m repro``: the command line lives in :mod:`repro.run.cli`."""

import sys

from repro.run.cli import main

sys.exit(main())
