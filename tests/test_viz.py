"""The Meshcat scene is built from the MuJoCo model and saved as a page that needs no network."""
import re

import numpy as np

from acder_lite import envs as E
from acder_lite import viz


def test_scene_from_a_short_rollout(tmp_path):
    env = E.make_env("FetchPush-v4", seed=0)
    rec = viz.record_rollout(env, policy=None, steps=6, seed=0, every=2)
    assert rec.n_frames == 4                                   # steps 0, 2, 4, 6
    assert rec.episode["state"].shape[0] == 7                   # T+1 states of the rollout
    geoms = viz.visible_geoms(env.model)
    assert len(geoms) >= 20                                    # the robot's meshes, table, object
    vis = viz.scene_from_recording(rec)
    try:
        size = viz.save_scene_html(vis, str(tmp_path / "scene.html"))
    finally:
        viz.close_visualizer(vis)
    html = (tmp_path / "scene.html").read_text()
    assert 1e5 < size < 2e6
    assert not re.search(r"<script[^>]+src=[\"']https?://", html)
    assert not list(tmp_path.glob("*.tmp"))
