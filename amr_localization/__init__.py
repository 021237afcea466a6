"""Where the robot is on a known map: a particle filter (MCL) and seed 000's beacon localizer."""
