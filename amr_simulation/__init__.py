"""A pymunk-backed differential-drive simulator and its ROS 2 node."""
