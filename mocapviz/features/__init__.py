"""Feature extraction: CCNet frame vectors and control signals."""
