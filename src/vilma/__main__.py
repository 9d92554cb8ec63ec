# PYTHON_ARGCOMPLETE_OK
"""``python -m vilma``: the ``vilma`` command."""

import sys

from vilma.app.cli import main

sys.exit(main())
