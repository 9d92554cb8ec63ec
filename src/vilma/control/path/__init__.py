"""Path controllers, one file each, registered by name: the original's Turn-Wheels (``vilma_heading``),
``pure_pursuit`` and ``stanley``."""

from vilma.control.path import pure_pursuit, stanley, vilma_heading  # noqa: F401  (they register themselves)
