"""Follow the original's recorded curve (the paper's Figure 12) to its end with the paper's controllers."""

import math
from importlib.resources import files

from vilma.control.driver import Driver, DriverParams
from vilma.sim import SimConfig, Simulator
from vilma.trajectory import Trajectory, increase_point_count, load_trajectory, smooth_iterative
from vilma.vehicle.state import VehicleState

log = files("vilma") / "scenarios/data/PositionLog_curved.txt"  # the curve the original car recorded, shipped
path = Trajectory(smooth_iterative(increase_point_count(load_trajectory(log)).xy))  # Generate Points, Smooth
start = VehicleState(x=path.xy[0, 0], y=path.xy[0, 1], yaw=path.heading_at(0.0))  # on its start, facing along it
sim = Simulator(SimConfig(initial=start))
driver = Driver(sim.config.vehicle, DriverParams(speed_controller="vilma_pid", path_controller="vilma_heading"),
                step=sim.config.step)
driver.follow(path, speed=5.0)  # or set_speed(v), hold_current_speed(), go_to(x, y, v), manual()
while not driver.status.arrived:  # until it comes to rest on the last point
    cmd = driver.update(sim.advance(driver.period_ticks))
    if cmd is not None:
        sim.command(cmd)

end = math.dist((sim.state.x, sim.state.y), path.xy[-1])
print(f"path: {path.length:.0f} m")
print(f"arrived: {driver.status.arrived}, at rest: {sim.state.speed < 0.05}")
print(f"stopped within 1 m of the end: {end < 1.0}")
print(f"left on the path: {driver.status.remaining:.0f} m")
