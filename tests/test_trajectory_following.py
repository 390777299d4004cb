"""Trajectory following (CCNet §4.3.2): the six paths, their per-frame walk, the type blend,
the distance to a polyline, and a whole generation with a model that walks sideways."""

from types import SimpleNamespace

import numpy as np
import pandas as pd
import pytest
import torch

from mocapviz.features.ccnet import FeatureLayout, Normaliser
from mocapviz.features.motion_types import MOTION_TYPES
from mocapviz.models.baseline import BaselineConfig, BaselineModel
from mocapviz.skeleton import CCNET_25_JOINTS
from mocapviz.tasks import trajectory_following as tf

LAYOUT = FeatureLayout(25, len(MOTION_TYPES))
ROOT = LAYOUT.x_blocks["root"]


def test_the_six_paths_load_start_at_the_origin_heading_forward():
    for name in tf.TRAJECTORIES:
        t = tf.load_trajectory(name)
        np.testing.assert_allclose(t.points[0], 0.0)
        assert t.points[1, 1] > 0 and abs(t.points[1, 0]) < 0.02      # first step along +Z
        assert 10 < t.arc[-1] < 25 and t.segments[0] == 0 and t.segments[-1] == 1
        assert set(tf.segment_types(t)) <= set(tf.FOLLOW_TYPES)
        assert tf.segment_types(t) == tf.segment_types(t)             # seeded
    c = tf.load_trajectory("circle")
    assert np.linalg.norm(c.points[-1] - c.points[0]) < 1.05          # 1 m lead-in, then a closed circle
    with pytest.raises(KeyError, match="unknown trajectory"):
        tf.load_trajectory("spiral")


def test_polyline_distance_hand_cases():
    line = np.array([[0.0, 0.0], [2.0, 0.0], [2.0, 2.0]])
    p = np.array([[1.0, 1.0], [3.0, -1.0], [1.0, -0.5], [2.0, 1.0]])
    np.testing.assert_allclose(tf.polyline_distance(p, line), [1.0, np.sqrt(2.0), 0.5, 0.0])


def test_coverage_counts_target_points_the_root_passed_within_half_a_metre():
    target = np.stack([np.zeros(11), np.arange(11.0)], 1)              # 0..10 m, a point per metre
    achieved = np.stack([np.full(43, 0.3), np.linspace(0, 4.2, 43)], 1)  # 0.3 m to the side, up to 4.2 m
    assert tf.coverage(target, achieved) == 5 / 11                      # 0..4 m; 5 m is 0.85 m away


def test_frame_path_walks_each_segment_at_its_speed():
    t = tf.Trajectory("line", np.array([[0.0, 0.0], [0.0, 10.0]]), np.array([0.0, 0.5, 1.0]), 0)
    pts, names = tf.frame_path(t, ["walk", "jog"], {"walk": 1.0, "jog": 2.0}, fps=8)   # steps exact in binary
    step = np.diff(pts[:, 1])
    np.testing.assert_allclose(step[:40], 0.125)     # 5 m at 1 m/s, 8 fps
    np.testing.assert_allclose(step[40:], 0.25)      # 5 m at 2 m/s
    assert len(pts) == 61 and pts[-1, 1] == 10.0
    assert names[40] == "walk" and names[41] == "jog"


def test_type_blend_reaches_the_new_type_in_20_frames():
    names = ["jog"] * 30 + ["walk"] * 30
    lab = tf.blended_types(names, "walk", len(MOTION_TYPES))
    w, j = MOTION_TYPES.index("walk"), MOTION_TYPES.index("jog")
    assert lab[0, j] == pytest.approx(1 / 20) and lab[19, j] == 1.0
    assert lab[30, w] == pytest.approx(1 / 20) and lab[49, w] == 1.0 and lab[49, j] == 0.0
    np.testing.assert_allclose(lab.sum(1), 1.0)


def test_place_turns_forward_onto_the_heading():
    np.testing.assert_allclose(tf.place(np.array([[0.0, 1.0]]), (1.0, 2.0), 0.0), [[1.0, 3.0]])
    a = tf.place(np.array([[0.0, 1.0]]), (0.0, 0.0), np.pi / 2)
    assert np.linalg.norm(a) == pytest.approx(1.0) and abs(a[0, 1]) < 1e-9


class Sideways(BaselineModel):
    """Always outputs a root velocity of (vx, 0) m/s in the heading frame (identity normaliser)."""

    def __init__(self, vx):
        super().__init__()
        self.cfg = BaselineConfig(n_x=LAYOUT.n_x, n_skel=LAYOUT.n_skel, n_types=len(MOTION_TYPES))
        self.vx = vx
        self.dummy = torch.nn.Parameter(torch.zeros(1))

    def run(self, inp, state=None):
        raw = torch.zeros(inp.shape[:2] + (self.cfg.n_out,))
        raw[..., self.cfg.output_slices["mean"].start + ROOT.start] = self.vx
        return raw, state


def fake_dataset(n_seed):
    n = n_seed + 5
    x = np.zeros((2 * n, LAYOUT.n_x), np.float32)
    x[:n, ROOT.start + 1] = 1.0   # the first clip's seed walks forward at 1 m/s, the second stands
    clips = pd.DataFrame(dict(start=[0, n], stop=[n, 2 * n], root_x=[0.0, 5.0], root_y=[0.9, 0.9],
                              root_z=[0.0, 5.0], heading=[0.0, np.pi / 2], type_index=[0, 0], split="test",
                              type="walk"))
    arrays = lambda i: dict(x=x[clips.start[i]:clips.stop[i]], traj=np.zeros((n, 12), np.float32),  # noqa: E731
                            skel=np.zeros(LAYOUT.n_skel, np.float32), type_index=0)
    return SimpleNamespace(clips=clips, clip_arrays=arrays, joint_names=CCNET_25_JOINTS)


def test_following_distance_of_a_sideways_walker_grows_as_hand_computed():
    n_seed, fps, v = 30, 60.0, 0.6
    # std 0.5 everywhere (1.0 would mark channels constant), means 0; a raw root velocity v is v/0.5 normalised
    norm = Normaliser(np.zeros(LAYOUT.n_continuous, np.float32), np.full(LAYOUT.n_continuous, 0.5, np.float32),
                      np.zeros(LAYOUT.n_skel, np.float32), np.ones(LAYOUT.n_skel, np.float32),
                      np.zeros(12, np.float32), np.ones(12, np.float32))
    ds = fake_dataset(n_seed)
    res = tf.follow(Sideways(v / 0.5), norm, ds, [0, 1], "straight", {"walk": 1.3, "jog": 3.0},
                    model_name="sideways", n_seed=n_seed)
    n = res.achieved.shape[1]
    # generated frame k (1..n) sits k v / fps to the side of the straight path, which starts where the seed ended
    expected = 100 * v / fps * (n + 1) / 2
    np.testing.assert_allclose(res.distance_cm, expected, rtol=1e-3)
    np.testing.assert_allclose(res.target[0, 0], [0.0, n_seed / fps], atol=1e-6)   # seed: 1 m/s along +Z
    np.testing.assert_allclose(res.target[1, 0], [5.0, 5.0], atol=1e-6)
    np.testing.assert_allclose(res.target[1, 1] - res.target[1, 0], [0.1, 0.0], atol=1e-3)   # heading pi/2: +Z -> +X
    table = tf.following_table([res])
    assert list(table.columns[:4]) == ["model", "mean_cm", "std_cm", "n"]
    assert table.n[0] == 2 and table.mean_cm[0] == pytest.approx(expected, rel=1e-3)
    assert res.covered.max() < 0.05    # it never moves along the path: only the first 0.5 m is near it
    # the timed distance sees that it never went along: at frame k the target is the path's arc
    # length s_k ahead and the walker k v / fps to the side, so the distance is sqrt(s_k^2 + side^2)
    arc = np.concatenate([np.zeros((2, 1)), np.cumsum(np.linalg.norm(np.diff(res.frame_target, axis=1), axis=-1), 1)], 1)
    s_k = arc + np.linalg.norm(res.frame_target[:, :1] - res.target[:, :1], axis=-1)
    side = v / fps * np.arange(1, n + 1)
    np.testing.assert_allclose(res.timed_cm, 100 * np.sqrt(s_k ** 2 + side ** 2).mean(axis=1), rtol=1e-3)
    # standing still: close to the curve (a small mean_cm), but it covers nothing and is far behind
    still = table.set_index("model").loc["stand_still"]
    assert still.mean_cm < 5.0 and still.covered < 0.05
    assert still.timed_cm == pytest.approx(100 * arc.mean(), rel=1e-3)
    assert still.timed_cm > 10 * still.mean_cm


def test_kept_frames_pose_the_generated_body_on_the_achieved_path():
    from mocapviz.skeleton import Skeleton
    n_seed = 30
    norm = Normaliser(np.zeros(LAYOUT.n_continuous, np.float32), np.full(LAYOUT.n_continuous, 0.5, np.float32),
                      np.zeros(LAYOUT.n_skel, np.float32), np.ones(LAYOUT.n_skel, np.float32),
                      np.zeros(12, np.float32), np.ones(12, np.float32))
    ds = fake_dataset(n_seed)
    lean = tf.follow(Sideways(1.2), norm, ds, [0, 1], "straight", {"walk": 1.3, "jog": 3.0}, n_seed=n_seed)
    assert lean.generated is None
    with pytest.raises(ValueError, match="keep=True"):
        lean.motion(0, None)
    res = tf.follow(Sideways(1.2), norm, ds, [0, 1], "straight", {"walk": 1.3, "jog": 3.0}, n_seed=n_seed, keep=True)
    np.testing.assert_allclose(res.achieved, lean.achieved)
    star = Skeleton(tuple(CCNET_25_JOINTS), np.array([-1] + [0] * 24), np.full((25, 3), 0.1))
    for i in range(2):
        m = res.motion(i, star, ik=False)
        assert m.n_frames == res.achieved.shape[1]
        np.testing.assert_allclose(m.root_positions[:, [0, 2]], res.achieved[i], atol=1e-9)
