"""The pybullet world: rooms, robot, camera, lidar, scenarios, a navigator stand-in, and the sim adapter."""
