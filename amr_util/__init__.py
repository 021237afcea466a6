"""amr_util: the bottom of the package graph, what every package of the suite shares (compare nav2_util).

Node plumbing: the lifecycle base that survives invalid transitions (managed_node), parameters stated
once (parameter_spec) and their docs tables (parameter_docs), parameter-file reading, share-directory
lookup (share), the suite's QoS profiles (qos), time stamps (stamps), the environment of child
processes and lock-free Ctrl-C/SIGTERM flags. Shared small things: planar geometry (geometry: 2D poses, angle wrap,
yaw quaternions, finite checks), differential-drive kinematics (diff_drive), the scan type (scan), message helpers
(messages) and the approximate-time synchronizer (sync). It imports nothing else of ours but amr_interfaces.
"""
