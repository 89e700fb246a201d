"""`viewslam evaluate`."""
