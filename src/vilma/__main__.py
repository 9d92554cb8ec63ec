# PYTHON_ARGCOMPLETE_OK
"""``python -m vilma``: the ``vilma`` command."""

from vilma.app.cli import entry

entry()
