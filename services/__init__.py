"""bimbot services: converter, component agents, planner, robot, physics, observer."""
