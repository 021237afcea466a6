"""A pymunk-backed differential-drive simulator and its ROS 2 node (worlds come from amr_maps.world)."""
