"""Neural motion models."""
