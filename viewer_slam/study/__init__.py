"""The seed study replayed from the runs its author published (``viewslam study``)."""
