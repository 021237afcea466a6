"""Evaluation at scale: episodes as pure functions of their spec, sweeps of them run locally or on a Dask
cluster (amr-evaluate), and a Gymnasium environment over the simulator library (amr/Maze-v0).

Above the other packages (it ties the simulator library to the controllers, as amr_bringup ties the
nodes): it may import any of them; none imports it (only bench/ and tests/ do).
"""
