"""The paper's Algorithm 1 parameters as the original shipped them (a module of its own, without imports, so that
the command line's help reads them at no cost)."""

ALPHA, BETA, TOLERANCE = 0.5, 0.1, 1e-6
"""The original's weight_data, weight_smooth and tolerance."""
