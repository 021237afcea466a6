"""amr_maps: occupancy grids, the ROS map_server file format, and the map node."""
