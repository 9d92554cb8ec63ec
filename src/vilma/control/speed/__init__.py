"""Speed controllers, one file each, registered by name: the original's gain-scheduled PID (``vilma_pid``) and a
feed-forward PI (``pi_ff``)."""

from vilma.control.speed import pi_ff, vilma_pid  # noqa: F401  (they register themselves)
