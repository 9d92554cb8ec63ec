"""Path controllers, one file each, that register themselves by name (:mod:`vilma.control.registry` imports
every module here): the original's Turn-Wheels (``vilma_heading``), ``pure_pursuit``, ``stanley`` and ``lqr``."""
