"""Denoising and completion (CCNet §4.3.1): alignment of the teacher-forced prediction, noise
units, the error, the dropped segments of completion, on hand-made cases."""

import numpy as np
import torch

from mocapviz.features.ccnet import FeatureLayout, Normaliser
from mocapviz.models.baseline import BaselineConfig, BaselineModel
from mocapviz.tasks import denoising as dn

J = 25
LAYOUT = FeatureLayout(J, 21)
N = LAYOUT.n_continuous


class CopyLast(BaselineModel):
    """Predicts x_{t+1} = x_t: its "denoised" frame t+1 is the input frame t."""

    def __init__(self):
        super().__init__()
        self.cfg = BaselineConfig(n_x=LAYOUT.n_x, n_skel=LAYOUT.n_skel, n_types=21)
        self.dummy = torch.nn.Parameter(torch.zeros(1))

    def run(self, inp, state=None):
        raw = torch.zeros(inp.shape[:2] + (self.cfg.n_out,))
        raw[..., self.cfg.output_slices["mean"]] = inp[..., :N]
        return raw, state


def identity_norm(n=N, std=0.5):
    # (std 1.0 would mark every channel constant: Normaliser.constant_channels)
    return Normaliser(np.zeros(n, np.float32), np.full(n, std, np.float32), np.zeros(LAYOUT.n_skel, np.float32),
                      np.ones(LAYOUT.n_skel, np.float32), np.zeros(12, np.float32), np.ones(12, np.float32))


def clip(t=50, seed=0):
    rng = np.random.default_rng(seed)
    return dict(x=rng.standard_normal((t, LAYOUT.n_x)).astype(np.float32),
                traj=rng.standard_normal((t, 12)).astype(np.float32),
                skel=np.zeros(LAYOUT.n_skel, np.float32), type_index=0)


def test_teacher_forced_alignment_prediction_of_t_plus_1_uses_frames_up_to_t():
    c = clip()
    rep = dn.Repairer(CopyLast(), identity_norm())
    out = rep.repair(c["x"], c["skel"], c["traj"], 0)   # normalised in, normalised out
    assert out.shape == (49, N)
    np.testing.assert_allclose(out, c["x"][:-1, :N], atol=1e-6)   # frame t+1 <- input frame t


def test_noise_on_continuous_channels_only_with_the_asked_std():
    x = np.zeros((4000, LAYOUT.n_x), np.float32)
    x[:, N:] = 1.0
    noisy = dn.add_noise(x, 0.05, N, np.random.default_rng(0))
    assert np.all(noisy[:, N:] == 1.0)
    assert abs(noisy[:, :N].std() - 0.05) < 0.001


def test_frame_error_is_euclidean_over_varying_channels():
    pred = np.array([[3.0, 4.0, 100.0]])
    assert dn.frame_errors(pred, np.zeros((1, 3)), np.array([True, True, False]))[0] == 5.0


def test_error_of_doing_nothing_on_a_still_clip_is_noise_times_sqrt_channels():
    # a still clip: copying the last (noisy) frame leaves the noise of that frame, norm ~ std sqrt(n)
    c = clip(t=400)
    c["x"][:] = c["x"][0]
    errs = dn.denoising_errors({"copy": dn.Repairer(CopyLast(), identity_norm())}, [c], [0.1], seed=3)
    assert abs(errs[(0.1, "copy")].mean() - 0.1 * np.sqrt(N)) < 0.05
    assert errs[(0.1, "copy")].shape == (399,)
    # the noisy input itself scores the same on a still clip
    assert abs(errs[(0.1, "noisy_input")].mean() - 0.1 * np.sqrt(N)) < 0.05
    table = dn.summary_table(errs, "D")
    assert list(table.columns) == ["dataset", "noise_std", "model", "mean", "std", "n"]
    assert set(table.model) == {"copy", "noisy_input"}


def test_noise_and_error_are_in_the_reference_units():
    # a model whose normaliser has std 2 sees the noise in its units as half, but the error is
    # reported back in the reference's: copying the last frame of a still clip scores the same
    c = clip(t=300)
    c["x"][:] = 0.0
    ref = identity_norm()
    a = dn.denoising_errors({"m": dn.Repairer(CopyLast(), identity_norm(std=2.0), reference=ref)}, [c], [0.1])
    b = dn.denoising_errors({"m": dn.Repairer(CopyLast(), ref)}, [c], [0.1])
    np.testing.assert_allclose(a[(0.1, "m")], b[(0.1, "m")], rtol=1e-5)


def test_constant_channels_are_written_as_their_training_value():
    norm = identity_norm()
    norm.x_std[:10] = 1.0  # std exactly 1: constant in the training data
    norm.x_std[10:] = 0.5
    c = clip()
    out = dn.Repairer(CopyLast(), norm).repair(norm.norm_x(c["x"]), c["skel"], c["traj"], 0)
    assert np.all(out[:, :10] == 0.0) and np.any(out[:, 10:] != 0.0)


def test_drop_segments_cover_the_share_in_runs_and_never_frame_zero():
    m = dn.drop_segments(301, 0.3, 30, np.random.default_rng(1))
    assert m.sum() == 90 and not m[0]
    starts = np.flatnonzero(np.diff(m.astype(int)) == 1) + 1
    assert len(starts) in (1, 2, 3)   # adjacent runs merge
    assert all(m[s:s + 30].all() for s in starts)


def test_zero_rotations_touches_only_the_leg_channels_on_the_frames():
    names = [f"j{i}" for i in range(J)]
    names[7:11] = dn.RIGHT_LEG
    ch = dn.leg_channels(LAYOUT, names)
    np.testing.assert_array_equal(ch, np.arange(21, 33))   # joints 7..10, 3 exp-map values each
    x = np.ones((5, LAYOUT.n_x))
    out = dn.zero_rotations(x, ch, [1, 3])
    assert out[[1, 3]][:, ch].sum() == 0 and out[[0, 2, 4]][:, ch].sum() == 36
    assert (out.sum() == x.sum() - 24) and x.sum() == 5 * LAYOUT.n_x


def test_error_shares_split_the_squared_error_by_block():
    pred, clean = np.zeros((2, N)), np.zeros((2, N))
    b = LAYOUT.x_blocks
    pred[0, b["rot"].start] = 3.0            # 9 in rot
    pred[1, b["vel"].start] = 1.0            # 1 in vel
    pred[1, b["pos"].start] = 100.0          # not varying: ignored
    varying = np.ones(N, bool)
    varying[b["pos"].start] = False
    shares = dn.error_shares(pred, clean, varying, LAYOUT)
    assert shares == {"rot": 0.9, "angvel": 0.0, "pos": 0.0, "vel": 0.1, "root": 0.0}


def test_sensitivity_is_one_for_copying_and_zero_for_ignoring_the_input():
    c = clip(t=300)
    assert abs(dn.sensitivity(dn.Repairer(CopyLast(), identity_norm()), [c], 0.1) - 1.0) < 0.02

    class Constant(CopyLast):
        def run(self, inp, state=None):
            return torch.ones(inp.shape[:2] + (self.cfg.n_out,)), state

    assert dn.sensitivity(dn.Repairer(Constant(), identity_norm()), [c], 0.1) == 0.0


def hand_skeleton():
    """The 25 CCNet joints: hips and shoulders across X, legs down Y, the right foot's toe ahead in Z."""
    from mocapviz.features.ccnet_joints import CCNET_25_PARENTS
    from mocapviz.skeleton import CCNET_25_JOINTS, Skeleton
    names = list(CCNET_25_JOINTS)
    off = {n: (0.0, 0.1, 0.0) for n in names}
    off.update({"Hips": (0.0, 0.0, 0.0), "LHipJoint": (0.1, 0.0, 0.0), "RHipJoint": (-0.1, 0.0, 0.0),
                "LeftShoulder": (0.15, 0.0, 0.0), "RightShoulder": (-0.15, 0.0, 0.0),
                **{f"{s}{j}": (0.0, -0.4, 0.0) for s in ("Left", "Right") for j in ("UpLeg", "Leg", "Foot")},
                "LeftToeBase": (0.0, 0.0, 0.1), "RightToeBase": (0.0, 0.0, 0.1)})
    parents = np.array([-1 if CCNET_25_PARENTS[n] is None else names.index(CCNET_25_PARENTS[n]) for n in names])
    return Skeleton(tuple(names), parents, np.array([off[n] for n in names]))


def test_leg_error_of_a_knee_bent_90_degrees_is_hand_computed():
    sk = hand_skeleton()
    x = np.zeros((3, LAYOUT.n_x))
    x[:, LAYOUT.x_blocks["root"].start + 3] = 1.0     # root height
    bent = x.copy()
    k = LAYOUT.x_blocks["rot"].start + 3 * sk.index("RightLeg")
    bent[1, k] = np.pi / 2                            # frame 1: the right knee turned 90 degrees about X
    err = dn.leg_errors(bent, x, sk)
    # knee -> foot (0, -0.4, 0) becomes (0, 0, +-0.4): the foot moves 0.4 sqrt 2; knee -> toe
    # (0, -0.4, 0.1) becomes (0, -+0.1, +-0.4): 0.3 up and 0.5 along Z; hip and knee stay
    foot, toe = 0.4 * np.sqrt(2), np.sqrt(0.3 ** 2 + 0.5 ** 2)
    np.testing.assert_allclose(err, [0.0, 100 * (foot + toe) / 4, 0.0], atol=1e-6)
    left = x.copy()
    left[:, LAYOUT.x_blocks["rot"].start + 3 * sk.index("LeftLeg")] = 1.0
    np.testing.assert_allclose(dn.leg_errors(left, x, sk), 0.0, atol=1e-9)   # only the right leg counts


def test_complete_leg_with_a_copying_model_repeats_the_corrupted_frames():
    sk = hand_skeleton()
    rng = np.random.default_rng(0)
    x = np.zeros((121, LAYOUT.n_x), np.float32)
    x[:, LAYOUT.x_blocks["rot"]] = 0.2 * rng.standard_normal((121, 75))
    c = dict(x=x, traj=np.zeros((121, 12), np.float32), skel=np.zeros(LAYOUT.n_skel, np.float32), type_index=0)
    res = dn.complete_leg(dn.Repairer(CopyLast(), identity_norm()), c, sk, share=0.25, segment=10, seed=1)
    assert res["dropped"].sum() == 30 and res["completed"].shape == (120, LAYOUT.n_x)
    legs = dn.leg_channels(LAYOUT, list(sk.names))
    d = np.flatnonzero(res["dropped"])
    assert np.all(res["corrupted"][d][:, legs] == 0) and np.all(res["corrupted_error"][~res["dropped"]] == 0)
    # copying the last input: completed frame t is corrupted frame t-1
    np.testing.assert_allclose(res["completed"][1:, :N], res["corrupted"][:-1, :N], atol=1e-5)
