"""The live control widget (paper §4.4) without a browser: its key buttons, ticks and BVH export
drive the recommended generator as the scripted sessions do."""

from __future__ import annotations

import numpy as np
import pytest

from mocapviz.features.motion_types import MOTION_TYPES, one_hot
from mocapviz.io.bvh import read_bvh
from mocapviz.tasks.control import KEY_TYPES, ControlSession


@pytest.fixture(scope="module")
def new_live(ds):
    pytest.importorskip("pyvista")
    from data_prep.sources import REPO_ROOT
    from mocapviz.training.checkpoint import load_checkpoint
    from mocapviz.viz.live_control import LiveControl
    from mocapviz.zoo import find_checkpoint
    model, norm, _ = load_checkpoint(find_checkpoint("ccnet_generate", cwd=REPO_ROOT))
    c = ds.clips
    row = int(np.flatnonzero((c.split == "test") & (c.type == "walk") & (c.stop - c.start > 130))[0])
    a, r = ds.clip_arrays(row), c.iloc[row]

    def make():
        session = ControlSession(model, norm, a["x"][:120], a["traj"][:120], a["skel"],
                                 one_hot(a["type_index"], model.cfg.n_types))
        return LiveControl(session, ds.skeleton(row), (r.root_x, r.root_y, r.root_z), r.heading,
                           type_index=a["type_index"])
    return make


def test_buttons_turn_left_change_the_type_and_the_take_exports(new_live, tmp_path):
    keys, plain = new_live(), new_live()
    for live in (keys, plain):
        for frame in range(90):
            if live is keys and frame % live.turn_frames == 0 and frame < 60:
                live.press("left")      # a click holds left for turn_frames frames: six clicks, 60 frames
            live.tick()
    assert keys.frame == plain.frame == 90
    heading = {k: live.session.root_path()[1] for k, live in (("keys", keys), ("plain", plain))}
    turned = heading["keys"][-1] - heading["keys"][119]
    assert turned - (heading["plain"][-1] - heading["plain"][119]) > np.radians(5)   # + is left
    keys.press("2")                     # jog, blended in over 20 frames
    for _ in range(25):
        keys.tick()
    assert keys.session.types.argmax() == MOTION_TYPES.index(KEY_TYPES["2"])
    m = read_bvh(keys.export_bvh(tmp_path / "take.bvh"))
    assert m.n_frames == keys.session.n_seed + 115
    assert np.allclose(m.positions()[-1], keys.motion().positions()[-1], atol=1e-3)
