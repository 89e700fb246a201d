"""`viewslam benchmark`."""
