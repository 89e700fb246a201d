"""`viewslam record` and `viewslam view`."""
