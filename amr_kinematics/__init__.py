"""Serial-arm and differential-drive kinematics: plain Python + numpy, no ROS."""
