"""The compact dataset copy for a lent GPU (data_prep.pack): rebuilt features equal the
original's to the quantisation, on real clips of every source (Bandai at its own 30 fps)."""

from dataclasses import replace

import numpy as np
import pytest

from data_prep.pack import pack, unpack

pytestmark = pytest.mark.slow


def subset(ds, rows):
    """The dataset of the clips ``rows`` only (frames re-stacked)."""
    clips = ds.clips.iloc[rows].reset_index(drop=True).copy()
    parts = [np.arange(r.start, r.stop) for r in clips.itertuples()]
    lengths = np.array([len(p) for p in parts])
    clips["start"] = np.concatenate([[0], np.cumsum(lengths)[:-1]])
    clips["stop"] = clips.start + lengths
    idx = np.concatenate(parts)
    return replace(ds, x=ds.x[idx], traj=ds.traj[idx], skel=ds.skel[rows], clips=clips, offsets=ds.offsets[rows])


def test_pack_round_trip_on_real_clips(data_dir, ds, tmp_path):
    rows = [int(ds.clips.index[ds.clips.source == s][0]) for s in ("hdm05", "cmu", "bandai")]
    small = subset(ds, rows)
    files = pack(small, data_dir, tmp_path, chunks=2, progress=False)
    assert [f.name for f in files] == ["ccnet.npz", "motions-0.npz", "motions-1.npz"]
    back = unpack(tmp_path, workers=1)
    assert list(back.clips["clip"]) == list(small.clips["clip"])
    n = len(ds.normaliser.x_mean)
    diff = np.abs(ds.normaliser.norm_x(back.x)[:, :n] - ds.normaliser.norm_x(small.x)[:, :n])
    assert diff.max() < 0.02          # training standard deviations; the input noise is 0.03
    assert np.median(diff) < 1e-3
    np.testing.assert_array_equal(back.x[:, n:], small.x[:, n:])     # contact labels exact
    np.testing.assert_allclose(back.traj, small.traj, atol=1e-3)     # c^d, metres
    # a corrupted copy is refused: the fingerprints no longer match
    with np.load(tmp_path / "ccnet.npz") as z:
        arrays = {k: z[k] for k in z.files}
    arrays["fingerprints"] = arrays["fingerprints"] + 1.0
    np.savez(tmp_path / "ccnet.npz", **arrays)
    with pytest.raises(ValueError, match="differ from the original"):
        unpack(tmp_path, workers=1)
