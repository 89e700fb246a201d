"""Feature detection, description, matching and robust motion estimation."""
