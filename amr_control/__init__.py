"""The wall follower, the approximate-time synchronizer and the lifecycle manager."""
