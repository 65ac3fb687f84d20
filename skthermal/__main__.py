"""``python -m skthermal`` runs the ``skthermal`` command."""

import sys

from skthermal.cli import main

sys.exit(main())
