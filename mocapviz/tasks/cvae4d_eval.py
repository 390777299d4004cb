"""Reconstruction of held-out cycles by the 4D CVAE and the PCA baseline (4D motion paper §4.3-4.4).

- test sets: one per value of the dataset's ``test_set`` column (held-out source, held-out
  subjects, held-out takes: :mod:`data_prep.body4d_splits`), over the held-out cycles only,
  mirrored copies left out (:func:`test_sets`);
- a CVAE reconstructs chi with z = mu (no sampling) and the cycle's true beta;
- the baseline is scikit-learn's PCA on the training cycles' [chi, beta] (flattened chi, beta
  appended), with dim(z) + dim(beta) components capped by the rank the training set allows
  (n_train - 1 after centring); a cycle is projected with its true beta and rebuilt, and, as in
  §4.4, meshed with the true beta rather than the rebuilt one (:class:`PCABaseline`);
- the metric is the **mean vertex error per sequence**: the Euclidean distance between
  corresponding vertices of the true and reconstructed meshes (every anny vertex, both meshed by
  :class:`mocapviz.bodies.torch_mesh.ChiMesher` from the first root at the origin), averaged over
  vertices and the 100 frames, in mm (:func:`vertex_errors`);
- :func:`error_table` summarises per (model, test set): n, mean, median, q1, q3 and Tukey's
  whisker ends in mm; :func:`boxplot_table` draws Tukey box plots (whiskers at 1.5 IQR) from
  such a table's rows, as the paper's Figs. 3-5;
- :func:`ablation_table` labels such rows with their ablation and value (Figs. 3-4) and adds
  every run's errors on all test sets together; :func:`ordering_steps` reads how the error
  changes from one value to the next;
- :func:`on_scale` re-expresses a dataset's translations in a checkpoint's scale, so a model
  trained on one build (the full dataset) reconstructs the cycles of another (the quick one).
"""

from __future__ import annotations

import numpy as np
import pandas as pd
import torch
from sklearn.decomposition import PCA

from mocapviz.training.cvae4d import split_indices

def test_sets(ds) -> dict[str, np.ndarray]:
    """Cycle indices of each test set: ``test_set`` value -> indices of the held-out cycles
    (``split`` not "train") carrying it, without mirrored copies."""
    _, held = split_indices(ds)
    test_set = ds.cycles["test_set"].fillna("").astype(str).to_numpy()
    return {t: held[test_set[held] == t] for t in sorted(set(test_set[held])) if t}


@torch.no_grad()
def reconstruct_cvae(model, chi: np.ndarray, beta: np.ndarray, batch: int = 64) -> np.ndarray:
    """chi_hat (B, N, C) of chi (B, N, C) on bodies beta (B, n_beta), with z = mu."""
    out = [model(torch.as_tensor(chi[i:i + batch]), torch.as_tensor(beta[i:i + batch]), sample=False)["chi"]
           for i in range(0, len(chi), batch)]
    return torch.cat(out).numpy()


class PCABaseline:
    """PCA on [chi (flattened), beta] of training cycles (module docstring)."""

    def __init__(self, chi: np.ndarray, beta: np.ndarray, latent: int):
        data = self._stack(chi, beta)
        self.requested = latent + beta.shape[1]
        self.rank_cap = len(data) - 1  # centred data of n rows spans at most n - 1 directions
        self.n_components = min(self.requested, self.rank_cap, data.shape[1])
        # sklearn picks a seeded randomized SVD for few components of a large set (the full SVD of
        # 3,656 x 13,006 costs minutes of CPU), the exact one otherwise
        self.pca = PCA(n_components=self.n_components, svd_solver="auto", random_state=0).fit(data)
        self.shape = chi.shape[1:]

    @staticmethod
    def _stack(chi, beta) -> np.ndarray:
        return np.concatenate([chi.reshape(len(chi), -1), beta], axis=1).astype(np.float64)

    def reconstruct(self, chi: np.ndarray, beta: np.ndarray) -> np.ndarray:
        """chi_hat (B, N, C): [chi, beta] projected on the components and rebuilt (beta_hat dropped)."""
        back = self.pca.inverse_transform(self.pca.transform(self._stack(chi, beta)))
        return back[:, :-beta.shape[1]].reshape((len(chi),) + self.shape).astype(np.float32)


def vertex_errors(mesher, chi: np.ndarray, chi_hat: np.ndarray, beta: np.ndarray, batch: int = 4) -> np.ndarray:
    """Mean vertex error (B,) in mm of each reconstructed cycle: distances between corresponding
    vertices of the meshes of chi and chi_hat (B, N, C) on bodies beta, averaged over vertices and frames."""
    return vertex_errors_many(mesher, chi, {"": chi_hat}, beta, batch)[""]


@torch.no_grad()
def vertex_errors_many(mesher, chi: np.ndarray, chi_hats: dict, beta: np.ndarray, batch: int = 4) -> dict:
    """:func:`vertex_errors` of several reconstructions (name -> chi_hat) of the same cycles,
    meshing the truth once per batch: {name: (B,) mm}."""
    out = {name: [] for name in chi_hats}
    for i in range(0, len(chi), batch):
        b = torch.as_tensor(beta[i:i + batch])
        truth = mesher(torch.as_tensor(chi[i:i + batch]), b, vertex_major=True)
        for name, chi_hat in chi_hats.items():
            pred = mesher(torch.as_tensor(chi_hat[i:i + batch]), b, vertex_major=True)
            out[name].append(1000 * (pred - truth).norm(dim=-1).mean(dim=(1, 2)).double())
    return {name: torch.cat(v).numpy() if v else np.zeros(0) for name, v in out.items()}


STAT_COLUMNS = ("mean", "median", "q1", "q3", "whislo", "whishi")


def error_table(errors: dict[tuple[str, str], np.ndarray]) -> pd.DataFrame:
    """One row per (model, test set): n, mean, median, q1, q3 of the per-sequence errors (mm),
    and Tukey's whisker ends (whislo, whishi: the most extreme errors within 1.5 IQR of the box)."""
    rows = []
    for (m, t), e in errors.items():
        q1, q3 = np.percentile(e, 25), np.percentile(e, 75)
        inside = e[(e >= q1 - 1.5 * (q3 - q1)) & (e <= q3 + 1.5 * (q3 - q1))]
        rows.append(dict(model=m, test_set=t, n=len(e), mean=np.mean(e), median=np.median(e), q1=q1, q3=q3,
                         whislo=inside.min(), whishi=inside.max()))
    return pd.DataFrame(rows).round({c: 2 for c in STAT_COLUMNS})


ABLATION_COLUMNS = ("ablation", "value", "model", "test_set", "n", *STAT_COLUMNS)


def ablation_table(errors: dict[tuple[str, str], np.ndarray], settings: dict) -> pd.DataFrame:
    """:func:`error_table` rows of ablation runs, labelled: ``errors`` {(run, test set): mm},
    ``settings`` {run: [(ablation, value), ...]} (a reference run may stand in several ablations).
    Each run also gets a test set "all": its errors on every test set together. Rows sorted by
    ablation, value, test set; columns :data:`ABLATION_COLUMNS`."""
    pooled = dict(errors)
    for run in {r for r, _ in errors}:
        pooled[(run, "all")] = np.concatenate([e for (r, _), e in sorted(errors.items()) if r == run])
    table = error_table(pooled)
    rows = [table[table.model == run].assign(ablation=ablation, value=float(value))
            for run, pairs in settings.items() for ablation, value in pairs]
    out = pd.concat(rows, ignore_index=True).sort_values(["ablation", "value", "test_set"], kind="stable")
    return out[list(ABLATION_COLUMNS)].reset_index(drop=True)


def ordering_steps(rows: pd.DataFrame, stat: str = "median") -> pd.DataFrame:
    """Consecutive steps of one ablation on one test set (``rows``: :func:`ablation_table` rows,
    any order): ``low``, ``high`` (values), ``low_mm``, ``high_mm`` (``stat`` of each),
    ``change_pct`` (high against low) and ``falls`` (the error is lower at the higher value)."""
    r = rows.sort_values("value")
    v, e = r["value"].to_numpy(), r[stat].to_numpy(dtype=float)
    return pd.DataFrame(dict(low=v[:-1], high=v[1:], low_mm=e[:-1], high_mm=e[1:],
                             change_pct=np.round(100 * (e[1:] / e[:-1] - 1), 1), falls=e[1:] < e[:-1]))


def paper_ordering_holds(steps: pd.DataFrame, ablation: str) -> bool:
    """Whether :func:`ordering_steps` of one ablation follow the paper's ordering: Fig. 3, the
    error falls with the latent size up to 64 (every step ending at 64 or below falls); Fig. 4,
    it rises with the KL weight (no step falls)."""
    if ablation == "latent":
        return bool(steps.loc[steps.high <= 64, "falls"].all())
    return not steps.falls.any()


def gaps_beyond_spread(phase1: tuple[float, float], phase2: tuple[float, float], pca: float) -> dict:
    """Fig. 5's ordering against the run-to-run spread, from two training seeds' mean errors of
    each phase: the spread (the larger seed-to-seed difference of a phase), the worst-case gaps
    (phase 1's better seed minus phase 2's worse; PCA minus phase 1's worse) and whether both
    gaps exceed the spread."""
    spread = max(abs(phase1[0] - phase1[1]), abs(phase2[0] - phase2[1]))
    gaps = (min(phase1) - max(phase2), pca - max(phase1))
    return dict(spread=spread, gap_phase1_phase2=gaps[0], gap_pca_phase1=gaps[1], holds=min(gaps) > spread)


def boxplot_table(ax, rows: pd.DataFrame, labels: list[str], title: str = ""):
    """The Tukey boxes of :func:`error_table` rows (one per label, in order; outliers not drawn)."""
    stats = [dict(label=lab, med=r["median"], q1=r["q1"], q3=r["q3"], whislo=r["whislo"], whishi=r["whishi"],
                  mean=r["mean"]) for lab, (_, r) in zip(labels, rows.iterrows())]
    ax.bxp(stats, showfliers=False, showmeans=True)
    ax.set_ylabel("mean vertex error per sequence (mm)")
    ax.set_title(title)
    return ax


def on_scale(ds, gamma_scale):
    """A copy of ``ds`` whose chi translations are divided by ``gamma_scale`` (3,) instead of the
    dataset's own scale (each build takes its scale from its own training cycles)."""
    from dataclasses import replace

    new = np.asarray(gamma_scale, dtype=np.float64)
    chi = ds.chi.copy()
    n_theta = chi.shape[-1] - 4
    chi[..., n_theta:n_theta + 3] *= (ds.gamma_scale / new).astype(chi.dtype)
    return replace(ds, chi=chi, meta={**ds.meta, "gamma_scale": new.tolist()})


def load_checkpoints(ds, paths: dict) -> dict:
    """CVAE models by name from checkpoint files (name -> path); warns when one was trained on
    other data than ``ds`` holds (then retrain: ``python -m data_prep train-cvae``)."""
    import warnings

    from mocapviz.training.cvae4d import data_fingerprint, load_cvae

    here, models = data_fingerprint(ds), {}
    for name, path in paths.items():
        models[name], meta = load_cvae(path)
        if meta["dataset"].get("fingerprint") != here:
            warnings.warn(f"{name} was trained on other data (dataset {meta['dataset'].get('hash')}) than it is "
                          f"evaluated on ({ds.meta.get('hash')}): retrain it (python -m data_prep train-cvae)")
    return models


def mean_cycle(chi_train: np.ndarray):
    """The baseline that does nothing: every cycle rebuilt as the training cycles' mean chi (meshed
    on the cycle's own beta)."""
    mean = np.asarray(chi_train, dtype=np.float32).mean(0)
    return lambda chi, beta: np.broadcast_to(mean, chi.shape).copy()


def reconstruction_errors(ds, models: dict, body=None, pca_latent: int | None = None,
                          progress: bool = False, with_pca: bool = True,
                          with_probes: bool = False) -> dict[tuple[str, str], np.ndarray]:
    """Per-sequence mean vertex errors (mm) of PCA ("pca", unless ``with_pca`` is False) and of
    each CVAE (name -> model) on each test set: {(model, test set): errors}. PCA's latent size is
    ``pca_latent`` (default: that of the first model) + dim(beta), capped by the training rank
    (:class:`PCABaseline`). ``with_probes`` adds the training-mean cycle ("mean_cycle"), the
    baseline that does nothing."""
    from tqdm.auto import tqdm

    from mocapviz.bodies.anny_model import body_model
    from mocapviz.bodies.torch_mesh import ChiMesher

    mesher = ChiMesher(body or body_model(), ds.gamma_scale)
    recon = {}
    if with_pca:
        latent = pca_latent or next(iter(models.values())).cfg.latent
        train_idx, _ = split_indices(ds)
        recon["pca"] = PCABaseline(ds.chi[train_idx], ds.beta[train_idx], latent).reconstruct
    recon.update({n: (lambda chi, beta, m=m: reconstruct_cvae(m, chi, beta)) for n, m in models.items()})
    if with_probes:
        recon["mean_cycle"] = mean_cycle(ds.chi[split_indices(ds)[0]])
    errors = {}
    for t, idx in tqdm(test_sets(ds).items(), desc="reconstruction errors", disable=not progress):
        chi_hats = {name: fn(ds.chi[idx], ds.beta[idx]) for name, fn in recon.items()}
        for name, err in vertex_errors_many(mesher, ds.chi[idx], chi_hats, ds.beta[idx]).items():
            errors[(name, t)] = err
    return errors


# ------------------------------------------------------------- codes optimised per cycle
# How much an encoder loses: the same decoder with its input code fitted to each test cycle's
# mesh (Adam, the body beta fixed at the truth), against the code the encoder (or PCA's
# projection, optimal in chi but not in vertices) gives. Fig. 5's "z optimised" rows.
FIT_SUFFIX = "_fit"
FIT_CONFIG = dict(steps=150, lr=0.05, fit_beta=False)  # fit_latent's defaults, half the step: codes start close
FIT_VERTICES = 512                                     # the fit's loss: a farthest-point subset of anny's vertices


class PCADecoder(torch.nn.Module):
    """A :class:`PCABaseline` as a decoder of its codes: chi_hat = mean + code @ components (the
    beta part of the rebuild dropped), so :func:`fit_latent` can fit its codes like a CVAE's z."""

    def __init__(self, pca: PCABaseline):
        super().__init__()
        n_chi = int(np.prod(pca.shape))
        self.pca, self.shape = pca, pca.shape
        self.register_buffer("mean", torch.as_tensor(pca.pca.mean_[:n_chi], dtype=torch.float32))
        self.register_buffer("components", torch.as_tensor(pca.pca.components_[:, :n_chi], dtype=torch.float32))

    def codes(self, chi: np.ndarray, beta: np.ndarray) -> torch.Tensor:
        return torch.as_tensor(self.pca.pca.transform(self.pca._stack(chi, beta)), dtype=torch.float32)

    def decode(self, z: torch.Tensor, beta: torch.Tensor) -> torch.Tensor:
        return (self.mean + z @ self.components).reshape((len(z),) + tuple(self.shape))


def start_codes(decoder, chi: np.ndarray, beta: np.ndarray) -> torch.Tensor:
    """The code a model gives a cycle without fitting: the CVAE encoder's mu, PCA's projection."""
    if isinstance(decoder, PCADecoder):
        return decoder.codes(chi, beta)
    with torch.no_grad():
        return decoder.encode(torch.as_tensor(chi))[0]


def fitted_errors(decoder, chi: np.ndarray, beta: np.ndarray, fit_mesher, mesher, batch: int = 16,
                  progress: bool = False) -> np.ndarray:
    """Per-cycle mean vertex errors (mm, on ``mesher``'s vertices) after fitting each cycle's code
    from :func:`start_codes` to its own mesh on ``fit_mesher``'s vertices (:data:`FIT_CONFIG`)."""
    from tqdm.auto import tqdm

    from mocapviz.tasks.cvae4d_fit import FitConfig, fit_latent

    out = []
    for i in tqdm(range(0, len(chi), batch), desc="codes fitted per cycle", disable=not progress, leave=False):
        c, b = chi[i:i + batch], torch.as_tensor(beta[i:i + batch])
        with torch.no_grad():
            target = fit_mesher(torch.as_tensor(c), b)

        def loss_fn(chi_hat, beta_):
            return (fit_mesher(chi_hat, beta_) - target).pow(2).sum(-1).flatten(1).mean(1)
        fit = fit_latent(decoder, loss_fn, start_codes(decoder, c, beta[i:i + batch]), b, FitConfig(**FIT_CONFIG))
        out.append(vertex_errors(mesher, c, fit.chi.numpy(), beta[i:i + batch]))
    return np.concatenate(out) if out else np.zeros(0)


def fit_subsets(ds, per_set: int, seed: int = 0) -> dict[str, np.ndarray]:
    """At most ``per_set`` cycles of each test set (seeded draw, sorted): fits cost ~100x a pass."""
    rng = np.random.default_rng(seed)
    return {t: np.sort(idx if len(idx) <= per_set else rng.choice(idx, per_set, replace=False))
            for t, idx in test_sets(ds).items()}


def fitted_reconstruction_errors(ds, models: dict, per_set: int, body=None, pca_latent: int | None = None,
                                 progress: bool = False) -> dict[tuple[str, str], np.ndarray]:
    """:func:`reconstruction_errors` with every code fitted per cycle (:func:`fitted_errors`), on
    :func:`fit_subsets`' cycles, for PCA and each CVAE: {(name + FIT_SUFFIX, test set): errors}."""
    from mocapviz.bodies.anny_model import body_model
    from mocapviz.bodies.torch_mesh import ChiMesher
    from mocapviz.tasks.cvae4d_completion import completion_mesher

    body = body or body_model()
    mesher = ChiMesher(body, ds.gamma_scale)
    fit_mesher = completion_mesher(body, ds.gamma_scale, FIT_VERTICES)
    latent = pca_latent or next(iter(models.values())).cfg.latent
    train_idx, _ = split_indices(ds)
    decoders = {"pca": PCADecoder(PCABaseline(ds.chi[train_idx], ds.beta[train_idx], latent)), **models}
    errors = {}
    for t, idx in fit_subsets(ds, per_set).items():
        for name, dec in decoders.items():
            errors[(name + FIT_SUFFIX, t)] = fitted_errors(dec, ds.chi[idx], ds.beta[idx], fit_mesher, mesher,
                                                           progress=progress)
    return errors
