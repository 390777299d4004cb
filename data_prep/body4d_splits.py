"""The body4d dataset's split and its normalisation scales (dataset knowledge, no I/O).

Split like the paper's (§4.1: whole AMASS sources held out for test) plus held-out subjects:

- ``held_out_source``: every cycle of a test source (default HDM05: five men, jog and sneak,
  none of whom the model sees);
- ``held_out_subjects``: every cycle of named subjects of the training sources (default CMU 35,
  walk, and CMU 09, run), so that walking is in test;
- ``held_out_takes``: a seeded share of Bandai's takes per content (:data:`TAKES_SHARE`): its
  actors are not recorded and share one skeleton, so no subject of it can be held out, yet it
  holds most of the walking, turning and walking back; these test unseen takes of a seen body;
- everything else trains: the rest of Bandai, and the other CMU subjects, which carry the
  training set's body variety.

HDM05 rather than CMU is the held-out source because CMU's nine other subjects are most of the
bodies a shape-conditioned decoder can learn from (HDM05 would leave three).

Normalisation scales come from the training cycles only (mirrored training copies included:
they are training data), so test data never sets them; test cycles may leave [-1, 1].
"""

from __future__ import annotations

import numpy as np
import pandas as pd

TEST_SOURCES = ("hdm05",)
TEST_SUBJECTS = ("cmu35", "cmu09")
TAKES_SHARE = 0.1
# Recorded genders (0 male, 1 female) for the shape prior (mocapviz.bodies.shape_fit). HDM05's
# five actors are men (as the HDM05 documentation states); CMU's subset README and
# index record no gender, and Bandai records neither actor nor gender per take: those stay 0.5.
SUBJECT_GENDER = {s: 0.0 for s in ("bd", "bk", "dg", "mm", "tr")}


def held_out_set(source: str, subject: str, clip: str = "", test_sources=TEST_SOURCES,
                 test_subjects=TEST_SUBJECTS, test_takes=frozenset()) -> str:
    """'held_out_source', 'held_out_subjects', 'held_out_takes' or '' (training) for a cycle's
    source, subject and clip."""
    if source in test_sources:
        return "held_out_source"
    if subject in test_subjects:
        return "held_out_subjects"
    return "held_out_takes" if clip in test_takes else ""


def held_out_takes(catalog: pd.DataFrame, share: float = TAKES_SHARE, seed: int = 0) -> frozenset:
    """Clips of a seeded ``share`` of Bandai's takes of each content (``description``), at least
    one of a content with three or more takes."""
    rng = np.random.default_rng(seed)
    out = []
    bandai = catalog[catalog["source"] == "bandai"]
    for _, g in bandai.groupby("description", sort=True):
        n = max(round(share * len(g)), int(len(g) >= 3))
        out += list(rng.permutation(g["clip"].values)[:n])
    return frozenset(out)


def gamma_scale(gamma: np.ndarray, train: np.ndarray) -> np.ndarray:
    """Per-axis translation scale (3,) in metres: max |Gamma| over the training cycles.

    gamma (N, F, 3) root translations from each cycle's first frame; train (N,) bool."""
    g = np.abs(np.asarray(gamma)[np.asarray(train, dtype=bool)])
    return np.maximum(g.max(axis=(0, 1)), 1e-6) if g.size else np.ones(3)

