"""`viewslam synth`."""
