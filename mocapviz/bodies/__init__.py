"""Body model (anny, cmu_mb rig): shape fitting to a skeleton, retargeting, mesh sequences."""

from mocapviz.bodies.anny_model import BETA_BOUNDS, BETA_LABELS, NEUTRAL_BETA, BodyModel, body_model, load_anny

__all__ = ["BETA_BOUNDS", "BETA_LABELS", "NEUTRAL_BETA", "BodyModel", "body_model", "load_anny"]
