"""`viewslam download` and `viewslam sequences`."""
