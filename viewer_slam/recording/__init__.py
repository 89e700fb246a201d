"""Events to Rerun recordings."""
