"""CCNet paper §4.6, Table 5: fine-tuning on a skeleton the network never saw, scored by rel_p.

The held-out subject (``tr``, HDM05) is the novel skeleton. Its clips are split again, on its own:

- **fine-tune** (``train``): the clips of the fine-tuning motion types, less one held-back clip.
  HDM05 has no plain walk for ``tr``: its locomotion is ``sneak`` and ``jog``
  (``jogLeftCircle...``), our stand-ins for the paper's walking and running; the two sets of
  :data:`FINETUNE_SETS` are sneak alone ("W") and sneak and jog ("W and R");
- **validation** (``val``): the held-back clip (the last sneak clip, the same in both sets),
  which picks the fine-tuned checkpoint, so that no scored clip chooses the model;
- **test**: every clip of the subject of a non-locomotion type (:data:`LOCOMOTION`), the same
  clips for every set and every model; a locomotion clip a set does not fine-tune on (jog, for
  sneak alone) is ``unused``.

:func:`finetune_split` makes that dataset (the subject's clips only, its rows copied out, the
normaliser unchanged: fine-tuning reads the new data in the pretrained network's units anyway);
:func:`rel_p_table` scores one-step prediction on it: every frame 1..T-1 of every test clip
predicted from the true frames before it (the mean output; before the clip, the causal
network's zero padding or the LSTM's empty state), :func:`mocapviz.metrics.rel_p` on the
continuous part of the frame vector in raw units (no IK), the per-frame terms' mean and std.
The predictors that do nothing (:mod:`mocapviz.tasks.do_nothing`) score the same frames.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pandas as pd

from mocapviz.metrics import rel_p_frames

# fine-tuning sets: our stand-ins for the paper's "W" and "W and R" (HDM05 has no plain walk for tr)
FINETUNE_SETS = {"walk (sneak)": ("sneak",), "walk and run (sneak, jog)": ("sneak", "jog")}
LOCOMOTION = ("sneak", "jog")  # never scored: the test clips are the subject's other motion types
VAL_TYPE = "sneak"   # the held-back validation clip: the last clip of this type (shared by both sets)


def finetune_split(ds, subject: str, train_types, val_type: str = VAL_TYPE, not_tested=None):
    """The dataset of ``subject``'s clips only, split for fine-tuning (module docstring): the
    clips whose ``type`` is in ``train_types`` -> ``train``, except the last one (by name) of
    ``val_type`` -> ``val``; every clip of a type not in ``not_tested`` (default
    ``train_types``) -> ``test``; the rest (types in ``not_tested`` but not fine-tuned on) ->
    ``unused``, so that every fine-tuning set of Table 5 is scored on the same test clips.
    Frame rows are copied (the result is small); normaliser, config and metadata are ``ds``'s."""
    c = ds.clips
    keep = np.flatnonzero((c.subject == subject).values)
    if not len(keep):
        raise KeyError(f"no clips of subject {subject!r} in the dataset")
    sub = c.iloc[keep].reset_index(drop=True)
    train_types = tuple(train_types)
    if val_type not in train_types:
        raise ValueError(f"the validation type {val_type!r} must be one of the fine-tuning types {train_types}")
    tuned = sub.type.isin(train_types).values
    tested = ~sub.type.isin(tuple(not_tested) if not_tested is not None else train_types).values
    val_candidates = sub.index[(sub.type == val_type).values]
    if len(val_candidates) < 2:
        raise ValueError(f"{subject} has {len(val_candidates)} {val_type} clip(s): none left to fine-tune on")
    val = sub.loc[val_candidates, "clip"].sort_values().index[-1]
    split = np.where(tuned, "train", np.where(tested, "test", "unused")).astype(object)
    split[val] = "val"
    rows = [np.arange(r.start, r.stop) for r in sub.itertuples()]
    lengths = np.array([len(r) for r in rows])
    stop = np.cumsum(lengths)
    sub = sub.assign(split=split, start=stop - lengths, stop=stop)
    idx = np.concatenate(rows)
    return replace(ds, x=ds.x[idx], traj=ds.traj[idx], skel=ds.skel[keep], offsets=ds.offsets[keep], clips=sub,
                   meta={**ds.meta, "finetune_subject": subject, "finetune_types": list(train_types)})


def split_clips(ds, split: str) -> list[dict]:
    """``clip_arrays`` of every clip of ``split`` with at least two frames."""
    c = ds.clips
    rows = np.flatnonzero(((c.split == split) & (c.stop - c.start >= 2)).values)
    return [ds.clip_arrays(int(i)) for i in rows]


def motion_minutes(ds, split: str = "train") -> float:
    """Minutes of motion (at the dataset's fps) in ``split``."""
    c = ds.clips[ds.clips.split == split]
    return float((c.stop - c.start).sum() / ds.config.fps / 60.0)


def one_step_rel_p(repairer, clips: list[dict]) -> np.ndarray:
    """Per-frame rel_p terms (frames 1..T-1 of every clip, concatenated) of ``repairer``'s
    teacher-forced one-step prediction (a :class:`mocapviz.tasks.denoising.Repairer` or a
    predictor of :mod:`mocapviz.tasks.do_nothing`): predicted and true frames in raw units, the
    continuous channels of x (the reference normaliser's width)."""
    ref = repairer.ref
    n = len(ref.x_mean)
    out = []
    for c in clips:
        x = np.asarray(c["x"])
        pred = repairer.repair(ref.norm_x(x), c["skel"], c["traj"], c["type_index"])
        out.append(rel_p_frames(pred * ref.x_std + ref.x_mean, x[1:, :n]))
    return np.concatenate(out)


def rel_p_table(repairers: dict, clips: list[dict]) -> pd.DataFrame:
    """Rows (model, rel_p, rel_p_std, n_frames) of :func:`one_step_rel_p` for every repairer
    (name -> repairer) on the same ``clips`` (std over frames, ddof 0)."""
    rows = []
    for name, rep in repairers.items():
        e = one_step_rel_p(rep, clips)
        rows.append(dict(model=name, rel_p=float(e.mean()), rel_p_std=float(e.std()), n_frames=int(len(e))))
    return pd.DataFrame(rows)
