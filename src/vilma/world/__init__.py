"""What the car drives in: road networks and the ego's task from CommonRoad scenarios
(:mod:`vilma.world.commonroad`)."""
