"""vilma: simulate, drive and monitor an autonomous car.

A Python rebuild of the VILMA project's MORSE + ROS + Qt architecture
(Ferreira, Garcia and Vaqueiro, UNICAMP). See the README for the programs.
"""

__version__ = "0.1.0"
