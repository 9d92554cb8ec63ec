"""vilma: simulate, drive and monitor an autonomous car.

A Python rebuild of the VILMA project's MORSE + ROS + Qt architecture
(Ferreira, Garcia and Vaqueiro, UNICAMP). See the README for the programs.
"""

import os as _os

from vilma.core.caches import ensure_numba_cache as _ensure_numba_cache

__version__ = "0.1.0"

_ensure_numba_cache(_os.path.dirname(_os.path.abspath(__file__)))  # before any module compiles: a read-only install
