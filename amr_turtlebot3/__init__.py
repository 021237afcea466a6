"""TurtleBot3 helpers: the odometry node that derives velocities from /odom poses."""
