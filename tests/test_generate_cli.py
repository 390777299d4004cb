"""The generate command: a user's own seed (real CMU, Bandai and HDM05 files) in, BVH out.

Motion quality is not asserted here (the benchmarks measure it): these tests pin the file
handling, the skeleton round trip and the command's errors.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
import tomllib
from pathlib import Path

import numpy as np
import pytest

from data_prep import zoo as repo_zoo
from data_prep.catalog import build_catalog, load_motion
from mocapviz import zoo
from mocapviz.cli import main
from mocapviz.io.bvh import read_bvh
from mocapviz.io.tpose import leading_tpose_frames
from mocapviz.tasks.generate_bvh import (GenerateError, generate_from_seed, limit_skeleton, load_seed, path_points,
                                         type_schedule)
from mocapviz.training.checkpoint import load_checkpoint
from mocapviz.tasks.generation_defaults import GENERATION_MODEL

ROOT = Path(__file__).resolve().parent.parent
CMU_WALK = ("cmu/35/35_01.bvh", None)                                    # 120 fps, T-pose frame 0
BANDAI_WALK = ("bandai/dataset-2/dataset-2_walk_active_027.bvh", None)   # 30 fps, reference root, 21 mapped joints
HDM05_JOG = ("hdm05/tr/HDM_tr_jogLeftCircle4StepsRstart_014_120.amc", "hdm05/tr/HDM_tr.asf")
SEEDS = {"cmu": CMU_WALK, "bandai": BANDAI_WALK, "hdm05": HDM05_JOG, "cmu-dropped": CMU_WALK}
# file joints left out between mapped ones (they move in the seed; the output holds them at
# their mean), and the CCNet joints they stood for made up
DROPPED_BETWEEN = {"LowerBack": None, "Neck": None, "Neck1": "Neck"}


@pytest.fixture(scope="module")
def checkpoint():
    return load_checkpoint(repo_zoo.committed_path("ccnet_default"))


def seed_paths(data_dir, key):
    seed, asf = SEEDS[key]
    return str(data_dir / seed), (str(data_dir / asf) if asf else None)


@pytest.fixture(scope="module", params=sorted(SEEDS))
def written(request, data_dir, checkpoint, tmp_path_factory):
    """2 s generated after a 1 s seed, written and read back."""
    seed_file, asf = seed_paths(data_dir, request.param)
    seed = load_seed(seed_file, asf)
    result = generate_from_seed(seed, *checkpoint, types=["walk"], seconds=2.0, seed_seconds=1.0,
                                joint_map=DROPPED_BETWEEN if request.param == "cmu-dropped" else None)
    out = tmp_path_factory.mktemp("gen") / f"{request.param}.bvh"
    from mocapviz.io.bvh import write_bvh
    write_bvh(result.motion, out)
    return request.param, seed, result, out, read_bvh(out)


def test_written_file_has_seed_then_generated_frames_at_60_fps(written):
    key, seed, result, _, back = written
    assert back.fps == 60.0 and result.n_seed == 60
    assert back.n_frames == 60 + 120 == result.motion.n_frames
    assert back.skeleton.names == seed.skeleton.names  # every joint of the seed, its own names


def test_fk_of_the_file_at_the_mapped_joints_equals_the_generated_positions(written):
    key, seed, result, _, back = written
    src = result.rig.source
    mapped = src >= 0
    generated = result.model_motion.positions()            # (120, 25, 3), after IK
    in_file = back.positions()[result.n_seed:][:, src[mapped]]
    assert np.abs(in_file - generated[:, mapped]).max() < 1e-4
    # the generated frames move (the integrated root at least), so the check is not vacuous
    assert np.ptp(generated[:, 0, [0, 2]], axis=0).max() > 0.05
    made_up = [n for n, s in zip(result.rig.names, src) if s < 0]
    if key == "bandai":  # CCNet joints Bandai lacks are made up; the rest map
        assert made_up == ["LHipJoint", "RHipJoint", "LowerBack", "Neck1"]
        # the file's reference root stays where the seed has it (its body root, Hips, travels)
        np.testing.assert_allclose(back.root_positions, seed.root_positions[:1].repeat(back.n_frames, 0), atol=1e-6)
    if key == "cmu-dropped":
        assert made_up == ["LowerBack", "Neck1"]
        neck = back.skeleton.index("Neck")  # dropped in between: moves in the seed, fixed after it
        local = back.rotations[:, neck]
        assert np.abs(local[:60] - local[0]).max() > 1e-3 and np.abs(local[60:] - local[60]).max() < 1e-5


def test_seed_frames_in_the_file_equal_the_resampled_seed(written):
    key, seed, result, _, back = written
    seed60 = seed if seed.fps == 60 else seed.resample(60)
    assert np.abs(back.positions()[:60] - seed60.positions()[:60]).max() < 1e-5


def test_file_uses_standard_rotation_channels_and_the_seed_unit(written):
    key, seed, _, out, back = written
    orders = {"".join(w[0] for w in line.split()[2:] if w.endswith("rotation"))
              for line in out.read_text().splitlines() if line.strip().startswith("CHANNELS")}
    assert orders <= {"ZXY", "ZYX"}
    unit = seed.meta["length_unit"] if key != "hdm05" else 0.01  # BVH: the seed's unit; ASF/AMC: cm
    assert back.meta["length_unit"] == pytest.approx(unit)


def test_cmu_t_pose_frame_is_skipped_like_the_catalog_skips_it(data_dir):
    """The T-pose detector agrees with the catalog's source knowledge (CMU first_frame = 1) on
    every CMU file, and finds none in HDM05 clips or Bandai takes."""
    cat = build_catalog(data_dir)
    cmu = cat[cat.source == "cmu"]
    assert len(cmu) == 15
    for row in cmu.itertuples():
        assert leading_tpose_frames(read_bvh(row.path)) == row.first_frame == 1, row.clip
    hdm = cat[cat.source == "hdm05"].iloc[::40]
    for row in hdm.itertuples():
        assert leading_tpose_frames(load_motion(row._asdict())) == row.first_frame == 0, row.clip
    for take in sorted((data_dir / "bandai").glob("dataset-*/*_walk_*.bvh"))[:5]:
        assert leading_tpose_frames(read_bvh(take)) == 0, take.name
    seed = load_seed(data_dir / CMU_WALK[0])  # the loader drops it
    assert seed.meta["tpose_frames"] == 1 and seed.n_frames == read_bvh(data_dir / CMU_WALK[0]).n_frames - 1


def test_type_schedule_switches_every_s_seconds():
    known = ("walk", "jog", "hop")
    oh = type_schedule(["jog", "hop"], known, n_seed=3, n_gen=130, switch_every=0.5, fps=60)
    idx = oh.argmax(-1)
    expected = [1] * 3 + [1] * 30 + [2] * 30 + [1] * 30 + [2] * 30 + [1] * 10
    assert oh.shape == (133, 3) and idx.tolist() == expected
    with pytest.raises(GenerateError, match="--switch-every"):
        type_schedule(["walk", "jog"], known, 3, 10, None, 60)


def test_limit_skeleton_clips_c_s_in_training_standard_deviations(checkpoint):
    norm = checkpoint[1]
    skel = norm.skel_mean + norm.skel_std * np.linspace(-6, 6, len(norm.skel_mean))
    z = (limit_skeleton(skel, norm, 3.0) - norm.skel_mean) / norm.skel_std
    np.testing.assert_allclose(z, np.clip(np.linspace(-6, 6, len(z)), -3, 3), atol=1e-4)
    np.testing.assert_allclose(limit_skeleton(skel, norm, 0.0), norm.skel_mean)
    np.testing.assert_allclose(limit_skeleton(skel, norm, np.inf), skel, rtol=1e-6)


def test_path_points_are_resampled_per_generated_frame():
    pts = path_points([[0.0, 0.0], [1.0, 2.0], [3.0, 2.0]], 5)
    np.testing.assert_allclose(pts, [[0, 0], [0.5, 1], [1, 2], [2, 2], [3, 2]])
    same = np.arange(10.0).reshape(5, 2)
    np.testing.assert_array_equal(path_points(same, 5), same)


def run_cli(capsys, *argv) -> tuple[int, str]:
    code = main(["generate", *argv])
    return code, capsys.readouterr().err


def test_a_path_file_steers_and_types_switch(data_dir, tmp_path, capsys):
    path = tmp_path / "path.json"
    path.write_text(json.dumps([[0.0, 0.0], [0.0, 1.5], [1.5, 3.0]]))
    out = tmp_path / "p.bvh"
    code, err = run_cli(capsys, "--seed", seed_paths(data_dir, "cmu")[0], "--seconds", "1", "--path", str(path),
                        "--type", "walk", "--type", "jog", "--switch-every", "0.5", "--sample", "--no-ik",
                        "--out", str(out), "--model", str(repo_zoo.committed_path("ccnet_default")))
    assert code == 0, err
    assert read_bvh(out).n_frames == 120 + 60


@pytest.mark.parametrize("case, args, message", [
    ("unknown type", ["--type", "moonwalk"], "unknown motion type 'moonwalk'; known: walk, jog, sneak"),
    ("no seed frame", ["--seed-seconds", "0"], "--seed-seconds 0 keeps no frame of the seed"),
    ("missing seed", ["--seed", "no/such/walk.bvh"], "seed file not found: no/such/walk.bvh"),
    ("missing model", ["--model", "ccnet_nonesuch"], "no model named 'ccnet_nonesuch': looked for"),
    ("amc without asf", ["--seed", "HDM05"], "pass its skeleton with --asf"),
    ("missing joint map", ["--joint-map", "no/map.json"], "joint map not found: no/map.json"),
])
def test_errors_are_one_clear_line(data_dir, tmp_path, capsys, monkeypatch, case, args, message):
    monkeypatch.chdir(ROOT)
    args = [str(data_dir / HDM05_JOG[0]) if a == "HDM05" else a for a in args]
    base = ["--seed", seed_paths(data_dir, "cmu")[0], "--seconds", "1", "--out", str(tmp_path / "e.bvh")]
    code, err = run_cli(capsys, *base, *args)
    assert code == 2 and message in err
    assert len(err.strip().splitlines()) == 1 and "Traceback" not in err
    assert not (tmp_path / "e.bvh").exists()


def test_joints_no_table_knows_are_placed_from_the_tree(data_dir, tmp_path, capsys, monkeypatch):
    monkeypatch.chdir(ROOT)
    text = (data_dir / CMU_WALK[0]).read_text().replace("JOINT LeftLeg", "JOINT Shin_Left")
    odd = tmp_path / "odd.bvh"
    odd.write_text(text)
    out = tmp_path / "o.bvh"
    code, err = run_cli(capsys, "--seed", str(odd), "--seconds", "1", "--out", str(out))
    assert code == 0, err
    assert "Shin_Left" in read_bvh(out).skeleton.names
    assert main(["map", str(odd)]) == 0
    table = capsys.readouterr().out.splitlines()
    assert table[0] == "mapping found by: the tree and the rest pose"
    assert table[2 + 3].split() == ["Shin_Left", "LeftLeg"]  # the fourth CCNet joint


def _left_leg_up(text: str) -> str:
    """The CMU file's text with its left shin and foot pointing up and LeftLeg renamed, so
    that no name table places it and the tree is not a humanoid's."""
    for bone in ("2.53442 -6.96327", "2.71068 -7.44755"):
        assert bone in text
        text = text.replace(bone, bone.replace(" -", " "))
    return text.replace("JOINT LeftLeg", "JOINT Shin_Left")


def test_a_skeleton_that_does_not_map_says_what_it_found_and_the_option(data_dir, tmp_path, capsys, monkeypatch):
    monkeypatch.chdir(ROOT)
    odd = tmp_path / "odd.bvh"
    odd.write_text(_left_leg_up((data_dir / CMU_WALK[0]).read_text()))
    out = tmp_path / "o.bvh"
    code, err = run_cli(capsys, "--seed", str(odd), "--seconds", "1", "--out", str(out))
    assert code == 2 and f"{odd}: not a humanoid skeleton" in err and "--joint-map FILE.json" in err
    assert "do not hang below the hips 'Hips'" in err and "LeftToeBase" in err
    assert len(err.strip().splitlines()) == 1 and not out.exists()
    jm = tmp_path / "map.json"
    jm.write_text(json.dumps({"Shin_Left": "LeftLeg"}))  # the override places what the names do not
    assert main(["map", str(odd), "--joint-map", str(jm)]) == 0
    table = capsys.readouterr().out.splitlines()
    assert table[0] == "mapping found by: joint names (cmu_motionbuilder convention), with the explicit map over it"
    assert table[2 + 3].split() == ["Shin_Left", "LeftLeg"]


def test_model_names_are_found_on_the_search_path(tmp_path, monkeypatch):
    committed = repo_zoo.committed_path("ccnet_default")
    monkeypatch.delenv(zoo.ZOO_ENV, raising=False)
    assert zoo.find_checkpoint("ccnet_default", cwd=ROOT / "tests").samefile(committed)  # a parent's models/zoo
    elsewhere = tmp_path / "zoo"
    elsewhere.mkdir()
    (elsewhere / "mine.safetensors").symlink_to(committed)
    monkeypatch.setenv(zoo.ZOO_ENV, os.pathsep.join([str(tmp_path / "empty"), str(elsewhere)]))
    assert zoo.find_checkpoint("mine", cwd=tmp_path) == elsewhere / "mine.safetensors"
    with pytest.raises(FileNotFoundError) as e:
        zoo.find_checkpoint("ccnet_default", cwd=tmp_path)
    assert str(elsewhere) in str(e.value) and str(tmp_path / "models" / "zoo") in str(e.value)
    with pytest.raises(FileNotFoundError, match="model file not found"):
        zoo.find_checkpoint(str(tmp_path / "nothing.safetensors"))


def test_console_script_runs(data_dir, tmp_path):
    scripts = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]["scripts"]
    assert scripts["mocapviz"] == "mocapviz.cli:main"
    out = tmp_path / "run.bvh"
    env = dict(os.environ, PYTHONPATH=str(ROOT), OMP_NUM_THREADS="1")
    res = subprocess.run([sys.executable, "-m", "mocapviz", "generate", "--seed", seed_paths(data_dir, "bandai")[0],
                          "--seconds", "2", "--out", str(out)], cwd=ROOT, env=env, capture_output=True,
                         text=True, timeout=300)
    assert res.returncode == 0, res.stderr[-2000:]
    assert "wrote" in res.stderr + res.stdout and "generate" in res.stderr  # the tqdm bar
    back = read_bvh(out)
    assert back.n_frames == 120 + 120 and back.fps == 60.0


def test_the_rig_sees_past_a_file_rest_pose(data_dir, checkpoint):
    """The same CMU walk written with its whole rest pose turned (a body lying along X, as
    Bandai's is) reaches the model unchanged: the rest alignment (and the twist fitted to the
    training rotations) undoes the file's convention."""
    from scipy.spatial.transform import Rotation

    from mocapviz.features.ccnet import motion_features
    from mocapviz.motion import Motion
    from mocapviz.skeleton import Skeleton, map_to_ccnet25
    from mocapviz.tasks.generate_bvh import mean_rest, rotation_stats
    from mocapviz.tasks.rig import ModelRig

    _, norm, meta = checkpoint
    ds = meta["dataset"]
    seed = load_seed(data_dir / CMU_WALK[0])[:120]
    q = Rotation.from_euler("ZYX", [90, 30, -20], degrees=True).as_matrix()
    sk = seed.skeleton
    turned_sk = Skeleton(sk.names, sk.parents, sk.offsets @ q.T, tuple((j, tuple(q @ np.asarray(o))) for j, o in sk.end_sites))
    rot = q @ seed.rotations @ q.T
    rot[:, 0] = seed.rotations[:, 0] @ q.T
    turned = Motion(turned_sk, rot, seed.root_positions, seed.fps)
    np.testing.assert_allclose(turned.positions(), seed.positions(), atol=1e-9)  # the same motion
    rigs = [ModelRig(m, map_to_ccnet25(sk.names), ds["joint_names"], ds["parents"], mean_rest(norm),
                     rotation_stats(norm, 25)) for m in (seed, turned)]
    a, b = (r.to_model(m) for r, m in zip(rigs, (seed, turned)))
    np.testing.assert_allclose(rigs[1].skeleton.offsets, rigs[0].skeleton.offsets, atol=1e-9)
    np.testing.assert_allclose(b.rotations, a.rotations, atol=1e-9)
    # the twist fit brings Bandai's rotations to the training range (standard normal data has mean
    # |z| 0.80): 1.5 -> 0.5 on this walk with the v3 model (no Bandai in training), -> 0.75 with v4's
    bandai = load_seed(data_dir / BANDAI_WALK[0]).resample(60)[:120]
    z = []
    for stats in (None, rotation_stats(norm, 25)):
        rig = ModelRig(bandai, map_to_ccnet25(bandai.skeleton.names), ds["joint_names"], ds["parents"],
                       mean_rest(norm), stats)
        x = motion_features(rig.to_model(bandai)).x
        z.append(np.abs(norm.norm_x(x)[:, :75]).mean())
    assert z[1] < 0.85 < 1.2 < z[0]
    # without the alignment the model would read other local rotations
    plain = [ModelRig(m, map_to_ccnet25(sk.names), ds["joint_names"], ds["parents"]) for m in (seed, turned)]
    assert np.abs(plain[1].to_model(turned).rotations - plain[0].to_model(seed).rotations).max() > 0.5


@pytest.mark.parametrize("key", ["cmu", "hdm05", "bandai"])
def test_a_seed_reaches_the_network_as_the_dataset_built_it(data_dir, ds, checkpoint, key):
    """A seed file with all 25 joints keeps its own rest pose, and a Bandai file takes the
    dataset's re-basing (known_rests.json) and its made-up joints, so its frame vectors equal
    the dataset's for the same clip: the network sees what it was trained on (aligned to the
    mean rest, a CMU walk's rotations were 0.8 standard deviations off, a Bandai walk's 1.1)."""
    from mocapviz.features.ccnet import motion_features
    from mocapviz.skeleton import map_to_ccnet25
    from mocapviz.tasks.generate_bvh import seed_rig
    model, norm, meta = checkpoint
    if key == "bandai":  # a walk the quick dataset holds
        clips = ds.clips[(ds.clips.source == "bandai") & (ds.clips.description == "walk")]
        seed_file, asf = str(next((data_dir / "bandai").glob(f"*/{clips['clip'].iloc[0]}.bvh"))), None
    else:
        seed_file, asf = seed_paths(data_dir, key)
    seed = load_seed(seed_file, asf).resample(60)[:200]
    rig = seed_rig(seed, map_to_ccnet25(seed.skeleton.names, None), meta["dataset"], norm)
    ours = motion_features(rig.to_model(seed), 60).x
    theirs = ds.clip_arrays(ds.clip_row(Path(seed_file).stem))["x"][:len(ours)]
    np.testing.assert_allclose(norm.norm_x(ours), norm.norm_x(theirs), atol=1e-3)


def test_known_rests_are_current_and_only_match_their_skeleton(data_dir, tmp_path):
    """known_rests.json is what ``python -m data_prep known-rests`` writes from the data, and
    it matches a Bandai take but not a CMU skeleton."""
    from data_prep.ccnet_dataset import write_known_rests
    from mocapviz.features.ccnet_joints import KNOWN_RESTS_FILE, known_alignment
    from mocapviz.skeleton import map_to_ccnet25
    fresh = write_known_rests(data_dir, tmp_path / "known_rests.json")
    assert json.loads(fresh.read_text()) == json.loads(KNOWN_RESTS_FILE.read_text())
    bandai = load_seed(data_dir / BANDAI_WALK[0])
    a = known_alignment(bandai.skeleton, map_to_ccnet25(bandai.skeleton.names))
    assert a is not None and len(a) == 21
    assert all(np.allclose(m @ m.T, np.eye(3), atol=1e-6) for m in a.values())   # rotations
    cmu = load_seed(data_dir / CMU_WALK[0])
    assert known_alignment(cmu.skeleton, map_to_ccnet25(cmu.skeleton.names)) is None


def test_seen_scale_brings_only_outlying_heights_into_the_training_range():
    from types import SimpleNamespace
    from mocapviz.tasks.generate_bvh import seen_scale
    norm = SimpleNamespace(skel_mean=np.array([0.9]), skel_std=np.array([0.05]))
    assert seen_scale(0.92, norm, 3.0) == 1.0                    # within: as it is
    assert seen_scale(0.5, norm, 3.0) == pytest.approx(0.75 / 0.5)  # a child's body up to mean - 3 std
    assert seen_scale(1.2, norm, 2.0) == pytest.approx(1.0 / 1.2)
    assert seen_scale(0.92, norm, 0.0) == pytest.approx(0.9 / 0.92)  # z = 0: the mean, as before


def test_seed_controls_leave_the_look_ahead_past_the_seed_to_the_generator():
    from mocapviz.features.ccnet import TRAJ_STEPS
    from mocapviz.tasks.generate_bvh import seed_controls
    traj = np.arange(100 * 12, dtype=np.float32).reshape(100, 12)
    out = seed_controls(traj)
    assert np.array_equal(out[:100 - TRAJ_STEPS[-1]], traj[:100 - TRAJ_STEPS[-1]])
    assert np.isnan(out[100 - TRAJ_STEPS[-1]:]).all() and not np.isnan(traj).any()
    assert np.isnan(seed_controls(traj[:30])).all()   # a seed shorter than the look-ahead: all the network's


def test_a_brisk_walk_seed_keeps_a_walkers_pace(data_dir):
    """The generate default model from a Bandai walk (1.44 m/s over its first 2 s): 10 s keep
    the seed's pace. With the seed's extrapolated c^d in its last second (before seed_controls)
    it broke into a run at 3.2 m/s."""
    from mocapviz import metrics
    model, norm, meta = load_checkpoint(repo_zoo.committed_path(GENERATION_MODEL))
    seed = load_seed(data_dir / "bandai/dataset-1/dataset-1_walk_active_001.bvh")
    result = generate_from_seed(seed, model, norm, meta, types=["walk"], seconds=10.0, ik=False)
    m = result.rig.to_model(result.motion)
    seed_speed = metrics.root_speed(m.root_positions[:result.n_seed], m.fps)
    speed = metrics.root_speed(m.root_positions[result.n_seed + 120:], m.fps)
    assert 0.6 * seed_speed < speed < 1.4 * seed_speed, (seed_speed, speed)


def test_pace_option_holds_or_follows_the_plan(data_dir, tmp_path, capsys):
    """--pace seed (the default) and --pace network write the same seed frames and different
    generated ones; an unknown pace is an argparse error."""
    files = {}
    for pace in ("seed", "network"):
        files[pace] = tmp_path / f"{pace}.bvh"
        code, err = run_cli(capsys, "--seed", seed_paths(data_dir, "bandai")[0], "--seconds", "1", "--no-ik",
                            "--pace", pace, "--out", str(files[pace]))
        assert code == 0, err
    held, own = read_bvh(files["seed"]), read_bvh(files["network"])
    np.testing.assert_array_equal(held.rotations[:120], own.rotations[:120])
    assert not np.array_equal(held.positions()[120:], own.positions()[120:])  # (a walk: by millimetres in 1 s)
    with pytest.raises(SystemExit):
        main(["generate", "--seed", "x.bvh", "--out", "y.bvh", "--pace", "user"])


def test_the_command_says_what_the_posture_search_kept(data_dir, tmp_path, capsys, monkeypatch):
    """With the default model (a latent one) and z from the seed, the command prints the search's
    one-line summary before the file it wrote; --z-search 0 prints none."""
    monkeypatch.chdir(ROOT)
    base = ["generate", "--seed", seed_paths(data_dir, "cmu")[0], "--seconds", "1", "--out", str(tmp_path / "s.bvh")]
    assert main(base) == 0
    out = capsys.readouterr().out
    assert "z searched over 64 codes: kept " in out and out.index("z searched") < out.index("wrote ")
    assert main(base + ["--z-search", "0"]) == 0
    assert "z searched" not in capsys.readouterr().out
