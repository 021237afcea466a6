"""amr_util: the node plumbing every package of the suite shares (compare nav2_util).

The lifecycle base that survives invalid transitions, parameters stated once (and their docs tables),
parameter-file reading, share-directory lookup, the suite's QoS profiles, the
environment of child processes and lock-free Ctrl-C/SIGTERM flags. It imports nothing
else of ours but amr_interfaces.
"""
