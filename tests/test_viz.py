"""Drawing geometry (numbers a picture shows) and small off-screen renders on real clips."""

from __future__ import annotations

import os
import subprocess
import sys

import numpy as np
import pytest

from data_prep.sources import DataNotFoundError, find_data_dir
from mocapviz.viz import geometry as geo
from mocapviz.viz.colors import subject_colors
from mocapviz.viz.plots import VICON_BONE_NAMES, bone_length_table, plot_bone_lengths

try:
    DATA = find_data_dir()
except DataNotFoundError as e:  # users without the data: nothing real to draw
    pytest.skip(str(e), allow_module_level=True)


@pytest.fixture(scope="module")
def catalog():
    from data_prep.catalog import build_catalog
    return build_catalog(DATA)


def _load(catalog, clip):
    from data_prep.catalog import load_motion
    return load_motion(catalog[catalog["clip"] == clip].iloc[0])


@pytest.fixture(scope="module")
def walk(catalog):
    return _load(catalog, "35_01")[:40]


@pytest.fixture(scope="module")
def skeletons(catalog):
    from data_prep.catalog import load_motion
    rows = catalog[catalog.source.isin(["hdm05", "cmu"])]
    return {s: load_motion(g.loc[g.frames.idxmin()]).skeleton for s, g in rows.groupby("subject", sort=False)}


# ------------------------------------------------------------------ geometry
def test_segments_join_parent_to_child(walk):
    pos = walk.positions()
    segs = geo.bone_segments(pos, walk.skeleton.parents)
    J = walk.skeleton.n_joints
    assert segs.shape == (walk.n_frames, J - 1, 2, 3)
    for j in range(1, J):
        np.testing.assert_allclose(segs[:, j - 1, 0], pos[:, walk.skeleton.parents[j]])
        np.testing.assert_allclose(segs[:, j - 1, 1], pos[:, j])
    # bone lengths on screen are the skeleton's, in every frame
    lengths = np.linalg.norm(segs[..., 1, :] - segs[..., 0, :], axis=-1)
    np.testing.assert_allclose(lengths, np.broadcast_to(walk.skeleton.bone_lengths()[1:], lengths.shape),
                               atol=1e-9)


def test_segments_reject_wrong_joint_count(walk):
    with pytest.raises(ValueError, match="31 joints"):
        geo.bone_segments(walk.positions()[:, :30], walk.skeleton.parents)


def test_end_sites_follow_their_joint(walk):
    ends = geo.end_site_segments(walk)
    sk = walk.skeleton
    assert ends.shape == (walk.n_frames, len(sk.end_sites), 2, 3)
    np.testing.assert_allclose(ends[:, :, 0], walk.positions()[:, [j for j, _ in sk.end_sites]])
    want = [np.linalg.norm(off) for _, off in sk.end_sites]
    np.testing.assert_allclose(np.linalg.norm(ends[:, :, 1] - ends[:, :, 0], axis=-1),
                               np.broadcast_to(want, ends.shape[:2]), atol=1e-9)
    head = [k for k, (j, _) in enumerate(sk.end_sites) if sk.names[j] == "Head"][0]
    assert np.all(ends[:, head, 1, 1] > ends[:, head, 0, 1])  # the head top is above the head


def test_zero_length_bones_are_not_drawn(walk):
    segs = geo.bone_segments(walk.positions()[0], walk.skeleton.parents)
    n_zero = int(np.sum(walk.skeleton.bone_lengths()[1:] < 1e-6))
    assert n_zero >= 5  # LHipJoint, RHipJoint, LowerBack, Neck, shoulders... in CMU BVH
    assert len(geo.nonzero_segments(segs)) == walk.skeleton.n_joints - 1 - n_zero


def test_standing_pose_stands(skeletons):
    for name, sk in skeletons.items():
        pose = geo.standing_pose(sk)
        assert abs(geo.lowest_point(pose)[0]) < 1e-9, name
        pos = pose.positions()[0]
        for hip, ankle in (("LeftUpLeg", "LeftFoot"), ("RightUpLeg", "RightFoot")):
            leg = pos[sk.index(ankle)] - pos[sk.index(hip)]
            assert abs(leg[0]) < 1e-9 and abs(leg[2]) < 1e-9 and leg[1] < -0.6, (name, leg)
        # arms (horizontal in the rest pose) drop by 65 degrees, hands stay on their own side
        for arm, elbow, hand, side in (("LeftArm", "LeftForeArm", "LeftHand", 1),
                                       ("RightArm", "RightForeArm", "RightHand", -1)):
            d = pos[sk.index(hand)] - pos[sk.index(arm)]
            reach = np.linalg.norm(sk.offsets[sk.index(elbow)] + sk.offsets[sk.index(hand)])
            assert d[1] == pytest.approx(-reach * np.sin(np.deg2rad(65)), abs=0.01), (name, d)
            assert side * d[0] == pytest.approx(reach * np.cos(np.deg2rad(65)), abs=0.01), (name, d)
        # and its height is within a few cm of the estimate the labels print
        assert sk.standing_height() - 0.14 < geo.highest_point(pose)[0] <= sk.standing_height() + 1e-9, name


def test_lineup_labels_and_spacing(skeletons):
    entries = geo.lineup(skeletons, gap=0.3)
    assert [e.name for e in entries] == list(skeletons)
    for e in entries:
        sk = skeletons[e.name]
        assert e.height == pytest.approx(sk.standing_height())
        assert e.label == f"{e.name}\n{sk.standing_height():.2f} m"
        assert e.label_at[1] == pytest.approx(geo.highest_point(e.pose)[0] + 0.1)
    xs = np.array([e.x for e in entries])
    assert np.all(np.diff(xs) > 0)  # left to right
    left = geo.all_segments(entries[0].pose)[..., 0].min()
    right = geo.all_segments(entries[-1].pose)[..., 0].max()
    assert left == pytest.approx(-right, abs=1e-9)  # the row is centred on x = 0
    # neighbours do not overlap: gap between extents along X
    for a, b in zip(entries, entries[1:]):
        right_a = geo.all_segments(a.pose)[..., 0].max()
        left_b = geo.all_segments(b.pose)[..., 0].min()
        assert left_b - right_a == pytest.approx(0.3, abs=1e-9)


def test_lineup_offsets_by_hand():
    np.testing.assert_allclose(geo.lineup_offsets([1.0, 2.0, 1.0], gap=0.5), [-2.0, 0.0, 2.0])


def test_ground_track_projects_root(walk):
    track = geo.ground_track(walk)
    np.testing.assert_allclose(track[:, [0, 2]], walk.root_positions[:, [0, 2]])
    floor = geo.floor_height(walk)
    assert np.all(track[:, 1] == floor)
    # feet touch the floor: the floor is within 2 cm of the toes' lowest points
    assert abs(floor - geo.lowest_point(walk).min()) < 0.02


def test_body_track_of_a_file_whose_root_stays_put():
    """Bandai's files keep joint_Root at the origin and translate the hips: the track is the
    hips', and a clip whose root moves keeps the root's."""
    from mocapviz.io.bvh import read_bvh
    m = read_bvh(DATA / "bandai/dataset-2/dataset-2_walk_normal_019.bvh")[:240]
    assert np.ptp(m.root_positions, axis=0).max() == 0.0
    hips = m.positions()[:, m.skeleton.index("Hips")]
    np.testing.assert_allclose(geo.body_root_positions(m), hips)
    assert np.linalg.norm(hips[-1, [0, 2]] - hips[0, [0, 2]]) > 1.0  # it walks away from the origin
    assert geo.travel_direction(m) @ (hips[-1] - hips[0]) / np.linalg.norm(hips[-1] - hips[0]) == pytest.approx(1, abs=0.05)


def test_body_track_is_the_root_when_the_root_moves(walk):
    np.testing.assert_array_equal(geo.body_root_positions(walk), walk.root_positions)


def test_joint_tracks_are_the_named_joints_positions(walk):
    pos = walk.positions()
    tracks = geo.joint_tracks(walk, ["Hips", "RightHand"])
    assert tracks.shape == (walk.n_frames, 2, 3)
    np.testing.assert_allclose(tracks[:, 0], walk.root_positions)       # the root joint sits at the root
    np.testing.assert_allclose(tracks[:, 1], pos[:, walk.skeleton.index("RightHand")])


def test_travel_direction_of_a_straight_walk(walk):
    d = geo.travel_direction(walk)
    step = walk.root_positions[-1] - walk.root_positions[0]
    step[1] = 0
    assert abs(abs(d @ step) / np.linalg.norm(step) - 1) < 0.02
    assert d[1] == 0 and np.linalg.norm(d) == pytest.approx(1)


def test_bone_length_table_matches_skeleton(skeletons, tmp_path):
    table = bone_length_table(skeletons)
    assert list(table.index) == list(skeletons)
    for name, sk in skeletons.items():
        for joint, label in VICON_BONE_NAMES.items():
            assert table.loc[name, label] == pytest.approx(sk.bone_lengths()[sk.index(joint)])
        assert table.loc[name, "height"] == pytest.approx(sk.standing_height())
    assert table.loc["bd", "thigh L"] == pytest.approx(0.414, abs=1e-3)  # HDM05 bd, by hand from its ASF
    fig = plot_bone_lengths(table, subject_colors(table.index), tmp_path / "b.png")
    assert (tmp_path / "b.png").stat().st_size > 10_000 and len(fig.axes) == 3


def test_subject_colors_distinct():
    subs = ["bd", "bk", "dg", "mm", "tr"] + [f"cmu{i}" for i in range(14)]
    cols = subject_colors(subs, ["hdm05"] * 5 + ["cmu"] * 14)
    assert len(set(cols.values())) == len(subs)


def test_save_figure_writes_the_file_and_its_folder(tmp_path):
    import matplotlib.pyplot as plt

    from mocapviz.viz import save_figure
    fig, ax = plt.subplots(figsize=(2, 1))
    ax.plot([0, 1], [0, 1])
    path = save_figure(fig, tmp_path / "new" / "f.png", dpi=50)
    assert path == tmp_path / "new" / "f.png" and path.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert save_figure(fig, None) is None
    plt.close(fig)


def test_viz_facade_exports_every_name_without_loading_pyvista():
    code = ("import sys, mocapviz.viz as v; assert 'pyvista' not in sys.modules; "
            "names = [getattr(v, n) for n in v.__all__]; print(len(names), 'pyvista' in sys.modules)")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    import mocapviz.viz as viz
    assert out.stdout.split() == [str(len(viz.__all__)), "True"]
    with pytest.raises(AttributeError):
        viz.no_such_name  # noqa: B018


# ------------------------------------------------------------------ rendering (off screen)
scene = pytest.importorskip("mocapviz.viz.scene")


def test_headless_default_is_set_before_pyvista():
    env = {k: v for k, v in os.environ.items() if k not in ("DISPLAY", "VTK_DEFAULT_OPENGL_WINDOW")}
    out = subprocess.run([sys.executable, "-c", "import mocapviz.viz.scene, os, pyvista as pv; "
                          "print(os.environ['VTK_DEFAULT_OPENGL_WINDOW'], pv.OFF_SCREEN)"],
                         env=env, capture_output=True, text=True, check=True)
    assert out.stdout.split() == ["vtkEGLRenderWindow", "True"]


def test_backend_choice(monkeypatch):
    for k in ("CI", "GITHUB_ACTIONS", "GITLAB_CI", "MOCAPVIZ_PYVISTA_BACKEND"):
        monkeypatch.delenv(k, raising=False)
    monkeypatch.setattr(scene, "_trame_available", lambda: True)
    assert scene.choose_notebook_backend(quick=True) == "static"
    assert scene.choose_notebook_backend(quick=False) == "trame"
    monkeypatch.setenv("CI", "true")
    assert scene.choose_notebook_backend(quick=False) == "static"
    monkeypatch.delenv("CI")
    monkeypatch.setattr(scene, "_trame_available", lambda: False)
    assert scene.choose_notebook_backend(quick=False) == "static"
    monkeypatch.setenv("MOCAPVIZ_PYVISTA_BACKEND", "client")
    assert scene.choose_notebook_backend(quick=True) == "client"


def _near(img, hex_color, tol=60):
    rgb = np.array([int(hex_color[i:i + 2], 16) for i in (1, 3, 5)])
    return np.abs(img[..., :3].astype(int) - rgb).sum(-1) < tol


def test_lineup_png_shows_each_subject(skeletons, tmp_path):
    import imageio.v2 as imageio
    two = {k: skeletons[k] for k in ("bk", "cmu91")}  # tallest and a short one
    colors = {"bk": "#d62728", "cmu91": "#1f77b4"}
    p = scene.skeleton_lineup(two, colors, width_px=480)
    assert [e.label.split("\n")[1] for e in p.lineup] == [f"{two[k].standing_height():.2f} m" for k in two]
    path = scene.save_screenshot(p, tmp_path / "lineup.png")
    p.close()
    img = imageio.imread(path)
    assert img.shape[1] == 480 and path.stat().st_size > 5_000
    red, blue = _near(img, colors["bk"]), _near(img, colors["cmu91"])
    assert red.sum() > 200 and blue.sum() > 100
    # bk stands left of cmu91, and is drawn taller (the lineup is in metres)
    ry, rx = np.nonzero(red)
    by, bx = np.nonzero(blue)
    assert rx.mean() < bx.mean()
    assert (ry.max() - ry.min()) > (by.max() - by.min())


def test_clip_gif_and_mp4(catalog, tmp_path):
    import imageio.v2 as imageio
    kick = _load(catalog, "143_24")  # 41 frames at 120 fps
    paths = scene.render_clip(kick, [tmp_path / "k.gif", tmp_path / "k.mp4"], fps=30,
                              window_size=(160, 96), progress=False)
    frames = imageio.mimread(paths[0])
    assert len(frames) == len(range(0, kick.n_frames, 4)) == 11
    assert frames[0].shape[:2] == (96, 160)
    assert not np.array_equal(frames[0], frames[-1])  # the body moved
    assert paths[1].stat().st_size > 1_000
    reader = imageio.get_reader(paths[1])
    assert reader.count_frames() == 11
    reader.close()


def test_frame_strip(walk, tmp_path):
    strip = scene.frame_strip(walk, tmp_path / "s.png", n=3, panel_size=(80, 120))
    assert strip.shape == (120, 3 * 80 + 2 * 3, 3)
    assert (tmp_path / "s.png").stat().st_size > 1_000
    panels = [strip[:, i * 83:i * 83 + 80] for i in range(3)]
    assert all((pn.min(axis=-1) < 150).sum() > 30 for pn in panels)  # a dark body in each panel


def test_frame_strip_follows_a_body_whose_root_stays_put(tmp_path):
    """A Bandai walk (joint_Root at the origin, the hips translated): the camera follows the
    hips, so the walker is as large in the last panel as in the first (it used to stay at the
    origin while the body walked 4 m away and shrank)."""
    from mocapviz.io.bvh import read_bvh
    m = read_bvh(DATA / "bandai/dataset-2/dataset-2_walk_normal_019.bvh")[:360]
    strip = scene.frame_strip(m, tmp_path / "s.png", n=3, panel_size=(80, 120))
    dark = [int((pn.min(axis=-1) < 150).sum()) for pn in _panels(strip, 3, 80)]
    assert min(dark) > 0.6 * max(dark), dark


# ------------------------------------------------------------------ CCNet application renders (Figs. 4-7)
def _panels(img, n, width):
    return [img[:, i * (width + 3):i * (width + 3) + width] for i in range(n)]


def test_denoising_render_draws_a_body_and_the_effector_paths_in_each_panel(walk, tmp_path):
    apps = pytest.importorskip("mocapviz.viz.apps_scene")
    img = apps.denoising_render({"noisy": walk, "denoised": walk, "clean": walk}, 20, path=tmp_path / "d.png",
                                panel_size=(160, 120))
    assert img.shape == (120, 3 * 160 + 2 * 3, 3) and (tmp_path / "d.png").stat().st_size > 1_000
    for pn in _panels(img, 3, 160):
        assert (pn.min(axis=-1) < 150).sum() > 30                         # a dark body
        for color in apps.EFFECTOR_COLORS[1::2]:                          # right hand, right toe paths
            assert _near(pn, color, tol=90).sum() > 5


def test_completion_render_shows_the_truth_behind_each_version(walk, tmp_path):
    apps = pytest.importorskip("mocapviz.viz.apps_scene")
    img = apps.completion_render(walk, {"corrupted": walk, "completed": walk}, [0, 20, 39], panel_size=(160, 120))
    assert img.shape == (120, 2 * 160 + 3, 3)
    for pn, color in zip(_panels(img, 2, 160), ("#d62728", apps.BODY_COLOR)):
        assert _near(pn, color, tol=120).sum() > 30


def test_following_render_draws_target_green_and_achieved_yellow(walk, tmp_path):
    apps = pytest.importorskip("mocapviz.viz.apps_scene")
    achieved = walk.root_positions[:, [0, 2]]
    target = achieved[[0, -1]] + [0.5, 0.0]          # a straight target half a metre to the side
    img = apps.following_render({"with body": (target, achieved, walk), "paths only": (target, achieved, None)},
                                n_poses=2, panel_size=(160, 120))
    assert img.shape == (120, 2 * 160 + 3, 3)
    body = []
    for pn in _panels(img, 2, 160):
        assert _near(pn, apps.TARGET_COLOR, tol=90).sum() > 20
        assert _near(pn, apps.ACHIEVED_COLOR, tol=90).sum() > 20
        body.append((pn.min(axis=-1) < 120).sum())
    assert body[0] > body[1] + 30                     # only the first panel has bodies
