"""Euler-angle wraps (acder_lite/runs/wraps.py): found by hand, summarised over runs."""

import json

import numpy as np
import pytest

from acder_lite.runs import wraps as W


def test_angle_wraps_by_hand():
    """A yaw turning steadily through +pi (the block barely moves) reads as one wrap;
    a fast but continuous turn and a jump just under pi read as none."""
    yaw = np.array([3.0, 3.1, -3.1, -3.0])  # +0.1, a wrap (+0.083 turned), +0.1
    rot = np.zeros((1, 4, 3))
    rot[0, :, 2] = yaw
    assert W.angle_wraps(rot).tolist() == [[False, True, False]]
    smooth = np.zeros((2, 3, 3))
    smooth[0, :, 0] = [-1.0, 0.5, 2.0]  # 1.5 rad a step, no wrap
    smooth[1, :, 1] = [0.0, np.pi - 1e-6, 0.0]  # just under pi each way
    assert not W.angle_wraps(smooth).any()
    # a perfect prediction but for that wrap still costs Eq. 4 its clip
    assert W.WRAP_ERROR == pytest.approx(19.74, abs=0.01) and W.WRAP_ERROR > 0.8


def _write(folder, env, name, seed, method, step, episode, success=1.0):
    p = folder / env / name / f"seed{seed}.json"
    p.parent.mkdir(parents=True, exist_ok=True)
    motion = dict(
        episodes=40,
        success=success,
        wrap_step_share=step,
        wrap_episode_share=episode,
    )
    p.write_text(json.dumps(dict(run="r", method=method, env=env, motion=motion)))


def test_summary_groups_cells_and_compares_the_two_kinds(tmp_path):
    a, b = tmp_path / "a", tmp_path / "b"
    _write(a, "FetchPush-v4", "her", 0, "her", 0.002, 0.05)
    _write(a, "FetchPush-v4", "her", 1, "her", 0.004, 0.10, success=0.5)
    _write(a, "FetchPush-v4", "acder", 0, "acder", 0.03, 0.4)
    _write(b, "FetchPush-v4", "her-bonus", 0, "her", 0.001, 0.0)
    # a run of a task without an object has no motion block: left out
    (a / "FetchReach-v4" / "her").mkdir(parents=True)
    (a / "FetchReach-v4" / "her" / "seed0.json").write_text(
        json.dumps(dict(run="r", method="her", env="FetchReach-v4"))
    )
    rows = W.summarize(a, b)
    assert [r["name"] for r in rows] == ["her-bonus", "her", "acder"]  # by step share
    her = rows[1]
    assert her["seeds"] == 2 and her["step_share"] == pytest.approx(0.003)
    assert (her["step_share_min"], her["step_share_max"]) == (0.002, 0.004)
    assert her["episode_share"] == pytest.approx(0.075) and her["success"] == 0.75
    assert [r["curiosity_reward"] for r in rows] == [False, False, True]
    header, body = W.table_rows(rows)
    assert len(header) == len(body[1]) and body[1][4] == "0.30% (0.20% – 0.40%)"


def test_which_methods_reward_curiosity():
    assert W.curiosity_in_reward("acder") and W.curiosity_in_reward("her-icm")
    assert not W.curiosity_in_reward("acder-no-curiosity")  # S-ICM ranks starts only
    assert not W.curiosity_in_reward("her") and not W.curiosity_in_reward("her-ebp")


def _buffer_reading(run, episodes, rows, at_clip, wraps_at_clip, wraps, candidates):
    """A reading of `buffer.sh` as its JSON holds it: `rows` minibatch rows, a share
    `at_clip` of them at Eq. 4's clip, `wraps` (share_of_rows, share_of_candidates)
    the share of the clipped rows that are wraps, and how many candidates there are."""
    share_of_rows, share_of_candidates = wraps
    return dict(
        run=run,
        method="acder",
        episodes=episodes,
        curiosity=dict(
            rows=rows,
            share_at_clip=at_clip,
            wraps=dict(
                share_of_rows=share_of_rows,
                share_at_clip=wraps_at_clip,
                candidates=candidates,
                share_of_candidates=share_of_candidates,
            ),
        ),
    )


def test_buffer_readings_read_only_files_with_a_wrap_reading(tmp_path):
    d = _buffer_reading(
        "results/FetchPush-v4/acder/seed2", 10400, 40960, 0.13, 0.52, (0.068, 0.725), 40
    )
    (tmp_path / "a").mkdir()
    (tmp_path / "a" / "r@abc.json").write_text(json.dumps(d))
    (tmp_path / "b.json").write_text(json.dumps(dict(run="her", curiosity=None)))
    (got,) = W.buffer_readings(tmp_path)  # the file without a wrap reading is left out
    assert got == d


def test_near_gimbal_lock_by_hand():
    """The pitch (second angle) at 1.5 rad, |cos| = 0.071 < 0.2, at step 1 of three
    observations: both steps touching it are near the lock; 1.3 rad (|cos| = 0.27) is
    not, unless the bound is raised to 0.3."""
    rot = np.array([[[0.0, 0.0, 0.0], [2.0, 1.5, -1.0], [0.1, 0.2, 0.3]]])
    assert W.near_gimbal_lock(rot).tolist() == [[True, True]]
    rot[0, 1, 1] = 1.3
    assert not W.near_gimbal_lock(rot).any()
    assert W.near_gimbal_lock(rot, cos_below=0.3).tolist() == [[True, True]]
    rot[0, 1, 1] = -np.pi / 2  # the other side face
    assert W.near_gimbal_lock(rot).tolist() == [[True, True]]
