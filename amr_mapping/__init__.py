"""Maps made by the robot."""
