"""``python -m forte.cli``: the same as the ``forte`` command."""

import sys

from forte.cli.main import main

sys.exit(main())
