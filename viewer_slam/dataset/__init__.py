"""RGB-D sequences: TUM folders, known sequences, downloads and synthetic scenarios."""
