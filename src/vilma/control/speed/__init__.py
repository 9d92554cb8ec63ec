"""Speed controllers, one file each, that register themselves by name (:mod:`vilma.control.registry` imports
every module here): the original's gain-scheduled PID (``vilma_pid``) and a feed-forward PI (``pi_ff``)."""
