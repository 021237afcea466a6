"""amr_viewer: a live view of any stack in the browser (viser), with controls for the simulator.

The scene and state logic are plain classes (no rclpy, no viser: `geometry`, `cdr`, `frames`, `state`,
`arms`, `parameters`, `topics`, `clicks`); `scene` and `panels` draw them with viser; `viewer_node` is the thin
lifecycle shell that wires them to ROS.
"""
