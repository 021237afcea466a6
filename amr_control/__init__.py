"""Controllers: the synchronized wall follower, its approximate-time synchronizer and scan reading."""
