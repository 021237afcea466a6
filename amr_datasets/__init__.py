"""Public robot datasets as first-class inputs."""
