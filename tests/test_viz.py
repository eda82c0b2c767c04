"""The Meshcat scene is built from the MuJoCo model and saved as a page that
needs no network."""

import re

import numpy as np
import pytest

from acder_lite.envs import fetch as E
from acder_lite.book import viz


def test_scene_from_a_short_rollout(tmp_path):
    env = E.make_env("FetchPush-v4", seed=0)
    rec = viz.record_rollout(env, policy=None, steps=6, seed=0, every=2)
    assert rec.n_frames == 4  # steps 0, 2, 4, 6
    assert rec.episode["state"].shape[0] == 7  # T+1 states of the rollout
    geoms = viz.visible_geoms(env.model)
    assert len(geoms) >= 20  # the robot's meshes, table, object
    vis = viz.scene_from_recording(rec)
    try:
        size = viz.save_scene_html(vis, str(tmp_path / "scene.html"))
    finally:
        viz.close_visualizer(vis)
    html = (tmp_path / "scene.html").read_text()
    assert 1e5 < size < 2e6
    assert not re.search(r"<script[^>]+src=[\"']https?://", html)
    assert not list(tmp_path.glob("*.tmp"))
    assert [p for p in viz.scene_objects(html) if "target" in p] == [
        "/meshcat/fetch/target"
    ]  # one goal, one marker


def _material_color(html: str, path: str) -> int:
    (cmd,) = [
        c
        for c in viz.scene_commands(html)
        if c.get("type") == "set_object" and c["path"] == path
    ]
    return cmd["object"]["materials"][0]["color"]


def test_target_nodes_name_one_marker_per_object():
    """One 3-D goal keeps the node `target` of every earlier scene (the saved Push scene
    itself: `test_scene_from_a_short_rollout`); a 6-D goal gives one per block."""
    assert viz.target_nodes(3) == [("target", "target0", slice(0, 3))]
    assert viz.target_nodes(6) == [
        ("target0", "target0", slice(0, 3)),
        ("target1", "target1", slice(3, 6)),
    ]


def test_multistep_scene_draws_both_blocks_and_both_targets(tmp_path):
    import mujoco
    from acder_lite.envs import multistep as M

    env = E.make_env(M.ENV_ID, seed=1)
    rec = viz.record_rollout(env, policy=None, steps=4, seed=1, every=2)
    assert rec.goal.shape == (3, 6)
    np.testing.assert_allclose(rec.goal[0], env.goal)
    vis = viz.scene_from_recording(rec)
    try:
        viz.save_scene_html(vis, str(tmp_path / "multi.html"))
    finally:
        viz.close_visualizer(vis)
    html = (tmp_path / "multi.html").read_text()
    objects = viz.scene_objects(html)
    targets = sorted(p for p in objects if p.rsplit("/", 1)[-1].startswith("target"))
    assert targets == [
        "/meshcat/fetch/target0",
        "/meshcat/fetch/target1",
    ]  # two target markers
    m = env.model
    for i, site in enumerate(M.TARGETS):  # each in its site's colour (red, blue)
        sid = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_SITE, site)
        assert _material_color(html, f"/meshcat/fetch/target{i}") == viz.hex_color(
            m.site_rgba[sid]
        )
    for name in M.OBJECTS:  # both blocks drawn, coloured as the XML colours them
        gid = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_GEOM, name)
        assert gid in viz.visible_geoms(m)
        assert _material_color(html, f"/meshcat/fetch/geom{gid}") == viz.hex_color(
            viz.geom_rgba(m, gid)
        )
    blue = [float(x) for x in M.OBJECT1_RGBA.split()]
    gid1 = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_GEOM, "object1")
    assert _material_color(html, f"/meshcat/fetch/geom{gid1}") == viz.hex_color(blue)


def test_record_states_takes_one_goal_or_one_per_frame():
    env = E.make_env("FetchPushMultiStep-v0", seed=0)
    states = np.stack([E.get_state(env)] * 3)
    rec = viz.record_states(env, states, env.goal)
    assert rec.goal.shape == (3, 6) and np.allclose(rec.goal, env.goal)
    rec = viz.record_states(env, states, np.arange(18.0).reshape(3, 6))
    assert rec.goal[2, 5] == 17.0
    with pytest.raises(ValueError, match="3k"):
        viz.record_states(env, states, np.zeros(4))


def _moving_arm(env, n: int = 3):
    """n stored states of Reach's arm, 3 steps apart, each with its own goal (1 cm
    further along every axis a state)."""
    states, goals = [], []
    for k in range(n):
        for _ in range(3):
            E.step(env, np.array([0.5, -0.5, 0.5, 0.0]))
        states.append(E.get_state(env))
        goals.append(env.goal + 0.01 * k)
    return np.stack(states), np.stack(goals)


def test_pool_scene_steps_through_the_states_with_a_marker_each(tmp_path):
    env = E.make_env("FetchReach-v4", seed=0)
    states, goals = _moving_arm(env)
    marks = np.array([[1.2, 0.7, 0.5], [1.3, 0.7, 0.5], [1.3, 0.8, 0.5]])
    vis = viz.pool_scene(env, states, goals, marks, dt=0.5)
    try:
        html = vis.static_html()
    finally:
        viz.close_visualizer(vis)
    objects = viz.scene_objects(html)
    assert {f"/meshcat/fetch/markers/m{k}" for k in range(3)} <= objects
    assert "/meshcat/fetch/target" in objects  # the goal, moving with the state
    kinds = {c.get("type") for c in viz.scene_commands(html) if isinstance(c, dict)}
    assert "set_animation" in kinds  # the arm and the goal move from state to state


def test_show_scene_frames_the_book_path_and_labs_file_server():
    from acder_lite.book.viz import show_scene

    a, b = (
        show_scene("01_push_random", height=300).data,
        show_scene("01_push_random").data,
    )
    assert 'src="../_static/scenes/01_push_random.html"' in a and 'height="300"' in a
    assert (
        '"/files/book/_static/scenes/01_push_random.html"' in a
        and 'indexOf("/lab/")' in a
    )
    assert (
        a.split('id="')[1].split('"')[0] != b.split('id="')[1].split('"')[0]
    )  # one id a frame


def test_plot_block_paths_draws_each_block_and_target_in_its_colour():
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from acder_lite.envs import multistep as M
    from acder_lite.book.plots import plot_block_paths
    from acder_lite.train.rollout import run_episodes

    def rgb(text):
        return [float(x) for x in text.split()[:3]]

    # the colours as the XML gives them: block 0 has the default geom rgba, so its
    # material block_mat's 0.2 grey applies; the fetch target site is red; the second
    # block and target are multistep's own
    blocks = [[0.2, 0.2, 0.2], rgb(M.OBJECT1_RGBA)]
    targets = [[1.0, 0.0, 0.0], rgb(M.TARGET1_RGBA)]
    for env_id, k in (("FetchPush-v4", 1), ("FetchPushMultiStep-v0", 2)):
        env = E.make_env(env_id, seed=0)
        rng = np.random.default_rng(0)
        ep = run_episodes([env], lambda o, g: rng.uniform(-1, 1, (1, 4)), 5)
        ep = {key: v[0] for key, v in ep.items()}
        fig, ax = plt.subplots()
        plot_block_paths(ax, ep, env)
        lines = ax.get_lines()
        assert len(lines) == 1 + 2 * k and len(ax.patches) == k
        for j in range(k):
            block, target = lines[1 + 2 * j], lines[2 + 2 * j]
            to_rgb = matplotlib.colors.to_rgb
            assert np.allclose(to_rgb(block.get_color()), blocks[j]), (env_id, j)
            assert np.allclose(to_rgb(target.get_color()), targets[j]), (env_id, j)
            assert np.allclose(ax.patches[j].get_edgecolor()[:3], targets[j])
            np.testing.assert_allclose(
                block.get_xydata(), ep["ag"][:, 3 * j : 3 * j + 2]
            )
            assert np.allclose(target.get_xydata()[0], ep["g"][0, 3 * j : 3 * j + 2])
        plt.close(fig)
        env.close()


def test_plot_mean_curves_reads_the_mean_curve_and_says_its_status():
    """Two Push seeds at 0.5, 0.9, 1.0 and 0.7, 0.9, 1.0: mean 0.6, 0.9, 1.0, which
    reaches 0.95 halfway between epochs 2 and 3 (2.5). One seed has ended, one trains.
    The legend counts seeds; a method without runs is 'not run yet'."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from acder_lite.book.plots import plot_mean_curves

    def run(seed, values, ended):
        rows = [
            dict(epoch=float(e), episodes=400.0 * e, test_success=v)
            for e, v in enumerate(values, 1)
        ]
        return dict(env="FetchPush-v4", name="her", seed=seed, rows=rows, ended=ended,
                    budget_epochs=50.0, episodes_per_epoch=400.0)  # fmt: skip

    runs = [run(0, [0.5, 0.9, 1.0], "budget"), run(1, [0.7, 0.9, 1.0], None)]
    fig, ax = plt.subplots()
    status = plot_mean_curves(ax, runs, "FetchPush-v4", ["her", "acder"])
    assert status == {
        "her": "2 seeds, 1 done, mean curve to epoch 3, first at 95% at epoch 2.50",
        "acder": "not run yet",
    }
    line = ax.get_lines()[0]
    assert line.get_label() == "DDPG+HER (2 seeds, 1 unfinished)"
    np.testing.assert_allclose(line.get_ydata(), [0.6, 0.9, 1.0])
    status = plot_mean_curves(ax, runs[:1], "FetchPush-v4", ["her"])
    assert status["her"].startswith("1 seed, 1 done, mean curve to epoch 3")
    labels = [
        x.get_label() for x in ax.get_lines() if not x.get_label().startswith("_")
    ]
    assert labels[-1] == "DDPG+HER (1 seed)"  # every seed ended: no count of unfinished
    plt.close(fig)


def test_the_band_of_a_success_rate_stays_within_0_and_1():
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from acder_lite.book.plots import plot_mean_curves

    # seeds at 1.0, 1.0 and 0.4 at the first evaluation: mean 0.8, one std above 1
    runs = [
        dict(env="FetchPush-v4", name="her", seed=k, ended="budget",
             rows=[dict(epoch=1.0, episodes=400.0, test_success=v),
                   dict(epoch=2.0, episodes=800.0, test_success=v)],
             budget_epochs=2.0, episodes_per_epoch=400.0)
        for k, v in enumerate([1.0, 1.0, 0.4])
    ]  # fmt: skip
    fig, ax = plt.subplots()
    plot_mean_curves(ax, runs, "FetchPush-v4", ["her"])
    (band,) = ax.collections
    ys = np.concatenate([p.vertices[:, 1] for p in band.get_paths()])
    assert ys.max() == 1.0 and ys.min() > 0.4  # clipped at 1, the lower side as drawn
    plt.close(fig)


def test_color_packs_red_green_blue_into_a_three_js_hex():
    """three.js reads 0xRRGGBB: red is 0xFF0000; 0.5 of 255 rounds to 128 = 0x80."""
    assert viz.hex_color([1.0, 0.0, 0.0, 1.0]) == 0xFF0000
    assert viz.hex_color([0.0, 0.5, 1.0]) == 0x0080FF


def test_scene_animates_each_frames_pose_and_goal_at_the_recordings_rate(tmp_path):
    """Three stored states of a moving arm, each with its own goal, 0.25 s apart: the
    env is put back, the animation runs at 1 / 0.25 = 4 frames a second, each geom
    starts at frame 0's pose and its track holds every frame's position and rotation,
    the goal's track every frame's goal."""
    import mujoco

    env = E.make_env("FetchReach-v4", seed=0)
    states, goals = _moving_arm(env)
    E.step(env, np.array([-0.5, 0.5, 0.0, 0.0]))
    now = E.get_state(env)
    rec = viz.record_states(env, states, goals, dt=0.25)
    np.testing.assert_array_equal(E.get_state(env), now)
    assert rec.dt == 0.25
    vis = viz.scene_from_recording(rec, cell=None)
    try:
        commands = viz.scene_commands(vis.static_html())
    finally:
        viz.close_visualizer(vis)
    (anim,) = [c for c in commands if c.get("type") == "set_animation"]
    tracks = {a["path"]: a["clip"] for a in anim["animations"]}
    assert {clip["fps"] for clip in tracks.values()} == {4}
    start = {
        c["path"]: c["matrix"] for c in commands if c.get("type") == "set_transform"
    }
    goal = tracks.pop("/meshcat/fetch/target")["tracks"]
    np.testing.assert_allclose([k["value"] for k in goal[0]["keys"]], rec.goal)
    np.testing.assert_allclose(start["/meshcat/fetch/target"][12:15], rec.goal[0])
    turned = 0
    for path, clip in tracks.items():
        i = int(path.rsplit("geom", 1)[1])
        position, rotation = (
            [k["value"] for k in t["keys"]] for t in clip["tracks"]
        )  # .position, then .quaternion (x, y, z, w)
        np.testing.assert_allclose(position, rec.xpos[:, i])
        np.testing.assert_allclose(start[path][12:15], rec.xpos[0, i])
        for k, q in enumerate(rotation):
            wxyz = np.empty(4)
            mujoco.mju_mat2Quat(wxyz, rec.xmat[k, i].ravel())
            assert abs(np.dot(np.r_[q[3], q[:3]], wxyz)) == pytest.approx(1.0)
        turned += not np.allclose(rec.xmat[0, i], rec.xmat[-1, i], atol=1e-3)
    assert turned  # some geom turns, so frame k's rotation is checked
