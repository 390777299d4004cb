"""Losses, checkpoints and the training loop."""
