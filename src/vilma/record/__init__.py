"""Recording, replay and the robotics ecosystem.

- :mod:`~vilma.record.mcap_file`, :mod:`~vilma.record.schemas`, :mod:`~vilma.record.cdr`: MCAP files of
  ROS 2 messages (CDR) for the sensors, standard types (``geometry_msgs``, ``sensor_msgs``, ``nav_msgs``) where
  one fits, Foxglove's well-known type for the car's frame, JSON for orders and statuses, chunks flushed at least
  every second;
  :mod:`~vilma.record.world_cdr`: camera images (JPEG or raw) with their camera info, and laser scans with their
  hits, as ``sensor_msgs``; :mod:`~vilma.record.world_schemas`: the same in Foxglove's JSON (live view, older files).
- :mod:`~vilma.record.recorder` (live programs, ``--record``), :mod:`~vilma.record.run` (``run.mcap`` of
  ``vilma run``), :mod:`~vilma.record.reader` (reading back, also files cut short).
- :mod:`~vilma.record.report` (``vilma report``), :mod:`~vilma.record.rosbag` (``vilma export rosbag2``),
  :mod:`~vilma.record.replay` (``vilma replay``), :mod:`~vilma.record.live` (``--foxglove``),
  :mod:`~vilma.record.ros1` (``vilma ros1-bridge``).
"""
