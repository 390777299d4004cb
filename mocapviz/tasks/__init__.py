"""Tasks built on trained models: generation, denoising, completion, control."""
