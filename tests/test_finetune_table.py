"""CCNet Table 5 (fine-tuning on the unseen subject): the re-split of the subject's clips, rel_p of
one-step prediction against a hand computation, the command's quick smoke run and the committed
table (data_prep/finetune_table.py, mocapviz/tasks/finetune.py)."""

from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from data_prep import finetune_table
from mocapviz.datasets.ccnet import CCNetDataset, DatasetConfig
from mocapviz.features.ccnet import Normaliser
from mocapviz.tasks import finetune as ft
from mocapviz.tasks.do_nothing import ConstantVelocity, CopyLast

RESULTS = Path(__file__).resolve().parent.parent / "results"


def tiny_dataset() -> CCNetDataset:
    """Clips of two subjects; frame rows numbered so that a copied row says where it came from."""
    spec = [("tr", "sneak", 5), ("tr", "sneak", 6), ("tr", "sneak", 7), ("tr", "jog", 5), ("tr", "jog", 4),
            ("tr", "squat", 3), ("tr", "kick", 4), ("tr", "squat", 5), ("bd", "walk", 6), ("bd", "squat", 3)]
    lengths = np.array([n for *_, n in spec])
    stop = np.cumsum(lengths)
    clips = pd.DataFrame(dict(clip=[f"HDM_{s}_{t}_{i:03d}" for i, (s, t, _) in enumerate(spec)],
                              subject=[s for s, *_ in spec], type=[t for _, t, _ in spec],
                              type_index=0, split="train", start=stop - lengths, stop=stop, trainable=True))
    n = int(stop[-1])
    x = np.repeat(np.arange(n, dtype=np.float32)[:, None], 4, axis=1)
    return CCNetDataset(x=x, traj=x[:, :2].copy(), skel=np.arange(len(spec), dtype=np.float32)[:, None],
                        clips=clips, normaliser=None, config=DatasetConfig(), joint_names=("Hips",),
                        offsets=np.zeros((len(spec), 1, 3)), parents=np.array([-1]), meta={"test_subject": "tr"})


def test_resplit_keeps_every_test_clip_out_of_fine_tuning():
    ds = tiny_dataset()
    for name, types in ft.FINETUNE_SETS.items():
        sub = ft.finetune_split(ds, "tr", types, not_tested=ft.LOCOMOTION)
        c = sub.clips
        assert set(c.subject) == {"tr"}, name
        tuned, val, test = (set(c["clip"][c.split == s]) for s in ("train", "val", "test"))
        assert not (tuned | val) & test and not tuned & val
        # the test clips: every clip of the subject of a type it does not fine-tune on, the same for every set
        assert set(c.type[c.split == "test"]) == {"squat", "kick"} and len(test) == 3
        assert set(c.type[c.split == "train"]) == set(types)
        assert val == {"HDM_tr_sneak_002"}                    # one held-back sneak clip, the last
        assert set(c.split[c.type == "jog"]) == ({"train"} if "jog" in types else {"unused"})
        # the rows copied are the clip's own
        for r in c.itertuples():
            orig = ds.clips[ds.clips["clip"] == r.clip].iloc[0]
            np.testing.assert_array_equal(sub.x[r.start:r.stop], ds.x[orig.start:orig.stop])
    assert ft.motion_minutes(ft.finetune_split(ds, "tr", ("sneak",)), "train") == pytest.approx(11 / 60 / 60)


def test_resplit_refuses_a_set_that_leaves_nothing_to_fine_tune_on():
    ds = tiny_dataset()
    with pytest.raises(ValueError):
        ft.finetune_split(ds, "bd", ("sneak",))
    with pytest.raises(KeyError):
        ft.finetune_split(ds, "nobody", ("sneak",))


def test_copy_last_rel_p_is_the_hand_computation():
    # two continuous channels and a contact label (not scored); the normaliser is arbitrary
    x = np.array([[3.0, 4.0, 1.0], [0.0, 5.0, 0.0], [6.0, 8.0, 1.0]])
    norm = Normaliser(np.array([1.0, -2.0], np.float32), np.array([2.0, 0.5], np.float32), np.zeros(1, np.float32),
                      np.ones(1, np.float32), np.zeros(2, np.float32), np.ones(2, np.float32))
    clip = dict(x=x, traj=np.zeros((3, 2)), skel=np.zeros(1), type_index=0)
    # frame 1 predicted as frame 0, frame 2 as frame 1
    hand = [np.hypot(3 - 0, 4 - 5) / 5, np.hypot(0 - 6, 5 - 8) / 10]
    np.testing.assert_allclose(ft.one_step_rel_p(CopyLast(norm), [clip]), hand, rtol=1e-6)
    # constant velocity: frame 2 predicted as 2 x_1 - x_0 = (-3, 6)
    cv = [hand[0], np.hypot(-3 - 6, 6 - 8) / 10]
    np.testing.assert_allclose(ft.one_step_rel_p(ConstantVelocity(norm), [clip]), cv, rtol=1e-6)
    t = ft.rel_p_table({"copy_last": CopyLast(norm)}, [clip, clip])
    assert t.n_frames.item() == 4 and t.rel_p.item() == pytest.approx(np.mean(hand))
    assert t.rel_p_std.item() == pytest.approx(np.std(hand))


@pytest.mark.slow
def test_quick_command_writes_the_table(tmp_path, data_dir):
    out = tmp_path / "table5.csv"
    from data_prep.cli import main
    assert main(["finetune-table", "--quick", "--steps", "1", "--baseline-steps", "1", "--out", str(out),
                 "--runs-dir", str(tmp_path / "runs"), "--data-dir", str(data_dir)]) == 0
    t = pd.read_csv(out)
    assert list(t.columns) == list(finetune_table.COLUMNS)
    assert set(t["mode"]) == {"quick"} and t.command.str.startswith("python -m data_prep finetune-table --quick").all()
    run = t[t.rel_p.notna()]
    assert {"ccnet_paper", "erd_quick", "dae_lstm_quick", "copy_last", "constant_velocity"} <= set(run.model)
    assert run.n_frames.nunique() == 1 and (run.rel_p > 0).all()     # every row on the same frames
    tuned = run[run.finetuned]
    assert set(tuned.fine_tuning) == set(ft.FINETUNE_SETS) and (tuned.ft_steps == 1).all()
    assert (tuned.ft_minutes_of_motion > 0).all() and (tuned.ft_cpu_minutes > 0).all()
    assert t[t.rel_p.isna()].note.str.startswith("not run").all()


def test_committed_table_has_every_row_and_says_how_it_was_made():
    t = pd.read_csv(RESULTS / finetune_table.OUT_NAME)
    assert list(t.columns) == list(finetune_table.COLUMNS)
    assert set(t["mode"]) == {"full"} and t.command.str.startswith("python -m data_prep finetune-table").all()
    run = t[t.rel_p.notna()]
    base = run[~run.finetuned].set_index("model")
    assert {"ccnet_paper", "erd_quick", "dae_lstm_quick", "copy_last", "constant_velocity"} <= set(base.index)
    tuned = run[run.finetuned]
    assert set(tuned[tuned.model == "ccnet_paper"].fine_tuning) == set(ft.FINETUNE_SETS)
    assert run.n_frames.nunique() == 1 and run.n_clips.nunique() == 1
    assert (tuned.ft_minutes_of_motion > 0).all() and (tuned.ft_steps > 0).all() and (tuned.ft_cpu_minutes > 0).all()
    assert set(t.model[t.rel_p.isna()]) == {"CCNet-D1", "CCNet-D2"}
    paper = pd.read_csv(RESULTS / "paper_ccnet_table5.csv")
    assert list(paper.columns) == ["model", "fine_tuning", "rel_p", "rel_p_std"] and len(paper) == 9
