"""Controllers: the synchronized wall follower and the path follower (pure pursuit), and scan sectors (no ROS), with
their nodes."""
