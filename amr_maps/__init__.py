"""amr_maps: the world format and its search path, occupancy grids, the ROS map_server file format, rasterizing,
a numpy ray caster, the maze generator (amr-maze), and the map_server node. Imports only amr_util of ours."""
