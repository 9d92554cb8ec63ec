"""The control and monitoring program (``vilma gui``): a Qt window to watch, drive and plot the car.

It meets the simulator and the driver only on the bus (:mod:`vilma.bus`):
with no endpoint it runs both in the background on a local bus
(:mod:`vilma.gui.backend`), with ``--connect`` it joins them over Zenoh.
Bus callbacks never touch widgets: :mod:`vilma.gui.bridge` keeps the latest
messages and the plot history and tells the GUI thread through signals.
"""
