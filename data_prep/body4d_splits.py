"""The body4d dataset's split, its bodies and its normalisation scales (dataset knowledge, no I/O).

The data hold few bodies: Bandai's takes (~90 % of the cycles) share one skeleton, HDM05 has
five men (jog cycles only), CMU a handful of walking and running subjects. A decoder conditioned
on beta learns nothing from a beta that is nearly constant, so bodies are spread:

- every Bandai take is retargeted onto a body drawn (seeded, per take) from the training
  bodies (:func:`draw_body`), Bandai's own included; the other sources stay on their own body;
- ``held_out_subjects``: the real cycles of named subjects (default HDM05 ``tr``, the
  CCNet paper's unseen subject, and CMU 35 and 09): unseen bodies, unseen performers -- all the
  cycles the data hold for them, fewer than 30;
- ``held_out_takes``: a seeded share of Bandai's takes per content (:data:`TAKES_SHARE`) on
  Bandai's own body: unseen takes of a seen body and seen motion types;
- ``held_out_bodies``: the same held-out takes retargeted onto a held-out subject's body
  (drawn per take): unseen takes on unseen bodies (a body the decoder never saw, carrying
  motion it never saw);
- ``validation`` (split ``val``): another seeded share of Bandai's takes (:data:`VAL_SHARE`),
  on drawn training bodies: every choice (epochs, learning rates, weights) is made on it, so
  the test sets are touched once;
- everything else trains.

Normalisation scales come from the training cycles only (mirrored training copies included:
they are training data), so test data never sets them; test cycles may leave [-1, 1].
"""

from __future__ import annotations

import zlib

import numpy as np
import pandas as pd

TEST_SOURCES = ()
TEST_SUBJECTS = ("tr", "cmu35", "cmu09")
TAKES_SHARE = 0.1
VAL_SHARE = 0.05
SPREAD_SOURCES = ("bandai",)  # sources whose takes are retargeted onto drawn bodies
# Recorded genders (0 male, 1 female) for the shape prior (mocapviz.bodies.shape_fit). HDM05's
# five actors are men (as the HDM05 documentation states); CMU's subset README and
# index record no gender, and Bandai records neither actor nor gender per take: those stay 0.5.
SUBJECT_GENDER = {s: 0.0 for s in ("bd", "bk", "dg", "mm", "tr")}


def held_out_set(source: str, subject: str, clip: str = "", test_sources=TEST_SOURCES,
                 test_subjects=TEST_SUBJECTS, test_takes=frozenset()) -> str:
    """'held_out_source', 'held_out_subjects', 'held_out_takes' or '' (training or validation)
    for a cycle's source, subject and clip, on the performer's own body."""
    if source in test_sources:
        return "held_out_source"
    if subject in test_subjects:
        return "held_out_subjects"
    return "held_out_takes" if clip in test_takes else ""


def _share_of_takes(catalog: pd.DataFrame, share: float, seed: int, exclude=frozenset()) -> frozenset:
    rng = np.random.default_rng(seed)
    out = []
    bandai = catalog[(catalog["source"] == "bandai") & ~catalog["clip"].isin(exclude)]
    for _, g in bandai.groupby("description", sort=True):
        n = max(round(share * len(g)), int(len(g) >= 3))
        out += list(rng.permutation(g["clip"].values)[:n])
    return frozenset(out)


def held_out_takes(catalog: pd.DataFrame, share: float = TAKES_SHARE, seed: int = 0) -> frozenset:
    """Clips of a seeded ``share`` of Bandai's takes of each content (``description``), at least
    one of a content with three or more takes."""
    return _share_of_takes(catalog, share, seed)


def validation_takes(catalog: pd.DataFrame, share: float = VAL_SHARE, seed: int = 0,
                     test_share: float = TAKES_SHARE) -> frozenset:
    """Like :func:`held_out_takes`, a share of the takes that are not held out for test."""
    return _share_of_takes(catalog, share, seed + 1, held_out_takes(catalog, test_share, seed))


def draw_body(clip: str, bodies, seed: int = 0) -> str:
    """A body for take ``clip`` from ``bodies`` (sorted first), seeded by the clip's name, so the
    draw does not depend on which other clips a build holds."""
    bodies = sorted(bodies)
    return bodies[np.random.default_rng([seed, zlib.crc32(clip.encode())]).integers(len(bodies))]


def gamma_scale(gamma: np.ndarray, train: np.ndarray) -> np.ndarray:
    """Per-axis translation scale (3,) in metres: max |Gamma| over the training cycles.

    gamma (N, F, 3) root translations from each cycle's first frame; train (N,) bool."""
    g = np.abs(np.asarray(gamma)[np.asarray(train, dtype=bool)])
    return np.maximum(g.max(axis=(0, 1)), 1e-6) if g.size else np.ones(3)

