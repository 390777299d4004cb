"""A compact copy of the CCNet dataset for a machine without the raw data (a lent GPU).

``python -m data_prep pack-ccnet --out cache/pack`` writes the full dataset's motions (each
clip's 25 local joint rotations as rotation vectors and its root path, at the source's own
frame rate, before Bandai's 30 -> 60 fps resampling; quantised to 1e-5 rad / 1e-5 m,
delta-coded along time, byte-shuffled and LZMA-compressed), the exact contact labels, and
everything else the dataset holds but x and c^d (split, c^s, rest offsets, the normaliser,
metadata), in ``--chunks`` files (4 by default, ~7 MiB each; 29 MiB in all where the ``.npz`` cache is
550 MB): the device tool carries at most 64 MiB of tree a call, and files carried by one call
stay on the machine for the next. :func:`unpack` rebuilds x and c^d from the motions with the
dataset's own pipeline (``Motion.resample``, :func:`mocapviz.features.ccnet.motion_features`,
in parallel processes) and checks them against per-clip fingerprints of the original (mean
and max |x| per block of x, in training standard deviations).
"""

from __future__ import annotations

import json
import lzma
import multiprocessing
import time
from concurrent.futures import ProcessPoolExecutor
from io import StringIO
from pathlib import Path

import numpy as np
import pandas as pd

STEP = 1e-5  # quantisation step of rotation vectors (rad) and root positions (m)
FINGERPRINT_BLOCKS = ("rot", "angvel", "pos", "vel", "root")


def _encode(a: np.ndarray) -> np.ndarray:
    """Quantised, delta-coded along time (axis 0), int32 bytes shuffled, LZMA: uint8 array."""
    q = np.round(a / STEP).astype(np.int64)
    d = np.diff(q, axis=0, prepend=np.zeros_like(q[:1])).astype(np.int32)
    shuffled = d.view(np.uint8).reshape(-1, 4).T.copy()  # the high bytes (mostly 0) together
    return np.frombuffer(lzma.compress(shuffled.tobytes(), preset=6), np.uint8)


def _decode(blob: np.ndarray, width: int) -> np.ndarray:
    b = np.frombuffer(lzma.decompress(blob.tobytes()), np.uint8).reshape(4, -1).T.copy()
    return np.cumsum(b.view(np.int32).reshape(-1, width).astype(np.int64), axis=0) * STEP


def fingerprints(ds) -> np.ndarray:
    """(n_clips, 2, n_blocks): per clip, the mean and the max |.| of each block of x, in
    training standard deviations (normalised units)."""
    xn = ds.normaliser.norm_x(ds.x)[:, :len(ds.normaliser.x_mean)]
    blocks = [ds.layout.x_blocks[b] for b in FINGERPRINT_BLOCKS]
    out = np.zeros((len(ds.clips), 2, len(blocks)))
    for i, r in enumerate(ds.clips.itertuples()):
        v = xn[r.start:r.stop]
        out[i, 0] = [v[:, sl].mean() for sl in blocks]
        out[i, 1] = [np.abs(v[:, sl]).max() for sl in blocks]
    return out


def pack(ds, root: Path, out_dir: Path, chunks: int = 2, progress: bool = True) -> list[Path]:
    """Write the compact copy of ``ds`` (built from the data folder ``root``) as
    ``out_dir/ccnet.npz`` (everything but the motions) and ``out_dir/motions-K.npz``."""
    from tqdm.auto import tqdm

    from data_prep.ccnet_dataset import _catalog, bandai_alignment
    from data_prep.catalog import load_motion
    from mocapviz.features.ccnet import prepare_motion
    from mocapviz.features.ccnet_joints import rebase_rest
    from mocapviz.rotations import matrix_to_rotvec

    cat = _catalog(ds.config, root).set_index("clip", drop=False)
    motions = []
    for r in tqdm(ds.clips.itertuples(), total=len(ds.clips), desc="pack motions", disable=not progress):
        m = load_motion(cat.loc[r.clip].to_dict())
        if r.source == "bandai":  # as data_prep.ccnet_dataset.load_ccnet_motion, before resampling
            m = rebase_rest(m, bandai_alignment(root))
        m = prepare_motion(m, m.fps)
        motions.append((m.fps, np.concatenate([matrix_to_rotvec(m.rotations).reshape(m.n_frames, -1),
                                               m.root_positions], axis=1)))
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    contact = ds.x[:, ds.layout.x_blocks["contact"]].astype(np.uint8)
    arrays = dict(fps=np.asarray([f for f, _ in motions]), lengths=np.asarray([len(a) for _, a in motions]),
                  contact=np.packbits(contact), skel=ds.skel, offsets=ds.offsets, parents=ds.parents,
                  fingerprints=fingerprints(ds), chunks=np.asarray(chunks),
                  clips=np.frombuffer(ds.clips.to_json(orient="split").encode(), np.uint8),
                  meta=np.frombuffer(json.dumps(dict(ds.meta, config=json.loads(ds.config.key()))).encode(),
                                     np.uint8))
    arrays.update({f"norm_{k}": v for k, v in ds.normaliser.state_dict().items()})
    (out_dir / "unpacked.npz").unlink(missing_ok=True)   # a cache of the previous copy
    written = [out_dir / "ccnet.npz"]
    np.savez(written[0], **arrays)
    for k, part in enumerate(np.array_split(np.arange(len(motions)), chunks)):
        path = out_dir / f"motions-{k}.npz"
        np.savez(path, clips=part, data=_encode(np.concatenate([motions[i][1] for i in part])))
        written.append(path)
    return written


def _clip_features(args):
    from mocapviz.features.ccnet import FPS, motion_features
    from mocapviz.motion import Motion
    from mocapviz.rotations import rotvec_to_matrix
    from mocapviz.skeleton import Skeleton

    names, parents, offsets, motion, fps = args
    n = len(motion)
    m = Motion(Skeleton(names, parents, offsets), rotvec_to_matrix(motion[:, :-3].reshape(n, -1, 3)), motion[:, -3:], fps)
    if abs(fps - FPS) > 1e-6:
        m = m.resample(FPS)
    f = motion_features(m, FPS)
    return f.x, f.traj


def unpack(folder: Path, workers: int = 8, tolerance: float = 0.02, cache: bool = False):
    """The :class:`mocapviz.datasets.ccnet.CCNetDataset` of a folder written by :func:`pack`.
    Raises if a rebuilt clip's fingerprint differs from the original's by more than
    ``tolerance`` training standard deviations; prints the largest difference. With ``cache``
    the rebuilt dataset is saved as ``folder/unpacked.npz`` and later calls load that (runs
    side by side on one machine then rebuild it once)."""
    from mocapviz.datasets.ccnet import CCNetDataset, DatasetConfig
    from mocapviz.features.ccnet import Normaliser

    t0, folder = time.perf_counter(), Path(folder)
    if (folder / "unpacked.npz").is_file():
        return CCNetDataset.load(folder / "unpacked.npz")
    with np.load(folder / "ccnet.npz") as z:
        a = {k: z[k] for k in z.files}
    meta = json.loads(a["meta"].tobytes().decode())
    clips = pd.read_json(StringIO(a["clips"].tobytes().decode()), orient="split")
    config = DatasetConfig(**{k: tuple(v) if isinstance(v, list) else v for k, v in meta["config"].items()})
    names = tuple(meta["joint_names"])
    motions = [None] * len(clips)
    for k in range(int(a["chunks"])):
        with np.load(folder / f"motions-{k}.npz") as z:
            part, data = z["clips"], _decode(z["data"], 3 * len(names) + 3)
        for i, m in zip(part, np.split(data, np.cumsum(a["lengths"][part])[:-1])):
            motions[i] = m
    jobs = [(names, a["parents"], a["offsets"][i], motions[i], float(a["fps"][i])) for i in range(len(clips))]
    # spawn, not fork: a forked worker of a process with BLAS or torch threads can deadlock
    with ProcessPoolExecutor(workers, mp_context=multiprocessing.get_context("spawn")) as pool:
        feats = list(pool.map(_clip_features, jobs, chunksize=8))
    lengths = np.asarray([len(f[0]) for f in feats])
    if not np.array_equal(lengths, (clips.stop - clips.start).values):
        raise ValueError(f"{folder}: rebuilt clips have other lengths than the dataset's")
    x = np.concatenate([f[0] for f in feats])
    traj = np.concatenate([f[1] for f in feats])
    n_contact = 2
    x[:, -n_contact:] = np.unpackbits(a["contact"])[:len(x) * n_contact].reshape(-1, n_contact)
    norm = Normaliser.from_state_dict({k[5:]: v for k, v in a.items() if k.startswith("norm_")})
    ds = CCNetDataset(x, traj, a["skel"], clips, norm, config, names, a["offsets"], a["parents"], meta)
    worst = np.abs(fingerprints(ds) - a["fingerprints"]).max()
    print(f"unpacked {len(clips)} clips, {len(x)} frames in {time.perf_counter() - t0:.1f} s; largest "
          f"fingerprint difference {worst:.2e} training std", flush=True)
    if worst > tolerance:
        raise ValueError(f"{folder}: rebuilt features differ from the original by {worst:.3g} std (> {tolerance})")
    if cache:
        ds.save(folder / "unpacked.npz")
    return ds


def add_arguments(p) -> None:
    p.add_argument("--out", default="cache/pack", help="folder of the compact copy")
    p.add_argument("--chunks", type=int, default=4, help="motion files (each carried by its own device call: "
                   "the tracked tree is ~52 MiB of the 64 a call carries)")
    p.add_argument("--data-dir")
    p.add_argument("--check", action="store_true", help="unpack it again here and compare")
    p.add_argument("--check-only", action="store_true", help="compare the copy in --out with the dataset")


def run(a) -> int:
    from data_prep.ccnet_dataset import DatasetConfig, build_dataset
    from data_prep.sources import find_data_dir

    ds = build_dataset(DatasetConfig(), a.data_dir)
    if not a.check_only:
        for path in pack(ds, find_data_dir(a.data_dir), Path(a.out), a.chunks):
            print(f"wrote {path} ({path.stat().st_size / 2**20:.1f} MiB)")
    if a.check or a.check_only:
        back = unpack(Path(a.out), workers=2)
        err = np.abs(back.normaliser.norm_x(back.x) - ds.normaliser.norm_x(ds.x)).max(0)
        print(f"largest per-frame difference (training std): {err.max():.2e}; median over channels {np.median(err):.2e}")
    return 0
