"""The deployable export: the same actions as the in-package policy, loadable with
nothing but torch, the simplified-state selection baked in; ONNX when its packages are
there."""

import json

import numpy as np
import pytest
import torch

from acder_lite.envs import fetch as E
from acder_lite.algo.core import Actor
from acder_lite.deploy.export import (
    META_FILE,
    build,
    export_torchscript,
    run_standalone,
)
from acder_lite.algo.normalizer import Normalizer
from acder_lite.envs.observations import simplified_indices
from acder_lite.train.rollout import Policy

from test_cli import one_line_error

pytestmark = pytest.mark.filterwarnings(
    "ignore:`torch.jit.load` is deprecated:DeprecationWarning"
)
"""torch 2.13 deprecates TorchScript (acder_lite.deploy.export's docstring); the robot
side
still loads it."""

SIZES = {
    ("FetchPush-v4", "full"): 25,
    ("FetchPush-v4", "simplified"): 11,
    ("FetchReach-v4", "simplified"): 5,
    ("FetchPushMultiStep-v0", "simplified"): 17,
}


def policy_dict(env_id: str, obs: str, seed: int = 0, spread: float = 0.3) -> dict:
    """An untrained policy with fitted normalisers (statistics far from 0/1, so
    normalising and its clip matter), as the trainer writes it; `spread`: the
    observations' std (a trained Fetch policy's are centimetres)."""
    n_o = SIZES[(env_id, obs)]
    n_g = 6 if env_id == "FetchPushMultiStep-v0" else 3
    rng = np.random.default_rng(seed)
    torch.manual_seed(seed)
    o_norm, g_norm = Normalizer(n_o), Normalizer(n_g)
    o_norm.update(rng.normal(1.0, spread, (500, n_o)))
    g_norm.update(rng.normal(0.8, spread / 3, (500, n_g)))
    pol = Policy(Actor(n_o + n_g, 4, 32, 3), o_norm, g_norm, 200.0)
    return dict(pol.state_dict(env_id, "acder"), obs=obs)


def inputs(n_o: int, n_g: int, seed: int = 1):
    """100 random inputs around the statistics, some past the clips
    (|x| > 200, |z| > 5)."""
    rng = np.random.default_rng(seed)
    o = rng.normal(1.0, 2.0, (100, n_o)).astype(np.float32)
    g = rng.normal(0.8, 1.0, (100, n_g)).astype(np.float32)
    o[:5] *= 300.0
    return o, g


@pytest.mark.parametrize("env_id,obs", list(SIZES))
def test_export_acts_as_the_policy(tmp_path, env_id, obs):
    pol = policy_dict(env_id, obs)
    path = tmp_path / "policy.ts"
    meta = export_torchscript(pol, str(path), "policy.pt")
    m = torch.jit.load(str(path))
    ref = Policy.from_state_dict(pol)
    env = E.make_env(env_id)
    full_names = E.obs_names(env, full=True)
    n_full, n_g = len(full_names), pol["norm"]["g"]
    o_full, g = inputs(n_full, n_g)
    idx = np.arange(n_full) if obs == "full" else simplified_indices(full_names)
    want = ref(o_full[:, idx], g)
    with torch.no_grad():
        got_full = m(torch.from_numpy(o_full), torch.from_numpy(g)).numpy()
        got_own = m(torch.from_numpy(o_full[:, idx]), torch.from_numpy(g)).numpy()
        one = m(
            torch.from_numpy(o_full[7]).double(), torch.from_numpy(g[7]).double()
        ).numpy()  # one input, float64
    assert np.abs(got_full - want).max() <= 1e-6
    assert np.abs(got_own - want).max() <= 1e-6
    assert np.abs(one - want[7]).max() <= 1e-6 and one.dtype == np.float32
    assert got_full.min() >= -1 and got_full.max() <= 1
    assert list(m.obs_names) == [full_names[i] for i in idx] == meta["obs_names"]
    assert list(m.full_obs_names) == full_names and len(m.goal_names) == n_g
    assert (m.env, m.obs) == (env_id, obs)


def test_metadata_gives_units_and_frame(tmp_path):
    """A robot engineer feeds the file from its metadata: every entry's unit, the
    world frame's landmarks and the control step, what the gripper command does."""
    pol = policy_dict("FetchPush-v4", "simplified")
    meta = export_torchscript(pol, str(tmp_path / "p.ts"))
    m = torch.jit.load(str(tmp_path / "p.ts"))
    assert list(m.obs_units) == meta["obs_units"] and len(meta["obs_units"]) == 11
    assert list(m.goal_units) == meta["goal_units"] and len(meta["goal_units"]) == 3
    assert all(u.startswith("m, world frame") for u in meta["goal_units"])
    unit = dict(zip(meta["full_obs_names"], meta["full_obs_units"]))
    assert len(unit) == len(meta["full_obs_units"]) == 25
    assert unit["grip_pos.x"].startswith("m, world frame")
    assert unit["object_rel_pos.y"].startswith("m, the block's position minus")
    assert "0.05 open" in unit["finger_l"] and unit["object_rot.z"].startswith("rad")
    assert unit["object_velp.x"].startswith("m per control step")
    w = meta["world"]
    assert w["control_dt_s"] == pytest.approx(0.04)
    assert np.allclose(w["initial_gripper_pos"], [1.363, 0.749, 0.416], atol=1e-3)
    assert w["block_rest_z"] == pytest.approx(0.4249, abs=1e-4)
    assert meta["action_units"][0].startswith("x 0.05 m")
    assert meta["action_units"][3].startswith("ignored") and w["gripper_blocked"]
    pick = dict(policy_dict("FetchPush-v4", "simplified"), env="FetchPickAndPlace-v4")
    meta = export_torchscript(pick, str(tmp_path / "pick.ts"))
    assert "> 0 opens" in meta["action_units"][3]


def test_wrong_widths_are_refused(tmp_path):
    path = tmp_path / "p.ts"
    export_torchscript(policy_dict("FetchPush-v4", "simplified"), str(path))
    m = torch.jit.load(str(path))
    with pytest.raises(
        Exception, match=r"observation has 12 numbers; allowed: 11 .* or 25"
    ):
        m(torch.zeros(12), torch.zeros(3))
    with pytest.raises(Exception, match="goal has 6 numbers; allowed: 3"):
        m(torch.zeros(11), torch.zeros(6))


def test_loads_in_a_process_without_acder_lite(tmp_path):
    """A robot-side program: torch only, another folder, no PYTHONPATH to the repo."""
    pol = policy_dict("FetchPush-v4", "simplified")
    path = tmp_path / "push.ts"
    export_torchscript(pol, str(path), "policy.pt")
    o, g = inputs(25, 3)
    out = run_standalone(str(path), o, g)
    assert out["imported"] == []
    want = Policy.from_state_dict(pol)(o[:, :11], g)
    assert np.abs(out["u"] - want).max() <= 1e-6
    meta = out["meta"]
    assert (meta["env"], meta["obs"]) == ("FetchPush-v4", "simplified")
    assert meta["source"] == "policy.pt" and len(meta["obs_names"]) == 11
    assert meta["clip_obs"] == 200.0 and meta["norm_clip"] == 5.0


def test_compare_with_package(tmp_path):
    """The book's check (chapter 10): export, act on the robot side and in the package
    on the same random inputs, compare."""
    from acder_lite.deploy.export import compare_with_package

    pol = policy_dict("FetchPush-v4", "simplified", spread=0.05)
    check = compare_with_package(pol, str(tmp_path / "push.ts"), source="p.pt", n=20)
    assert check["imported"] == [] and check["gap"] <= 1e-6
    # inputs where the policy acts, not pinned at the normalisers' clip (a tenth of
    # the rows past it on purpose)
    assert 0.0 < check["clipped"] < 0.15
    assert check["meta"]["source"] == "p.pt" and (tmp_path / "push.ts").is_file()


def test_build_refuses_a_policy_whose_sizes_are_not_its_task(tmp_path):
    from acder_lite.io import CheckpointError

    pol = policy_dict("FetchPush-v4", "full")
    pol["obs"] = "simplified"  # 25 inputs recorded as the 11-entry set
    with pytest.raises(CheckpointError, match="observation/goal/action sizes 25/3/4"):
        build(pol)


def test_metadata_says_how_far_the_run_trained(tmp_path):
    """A policy.pt carries its run's epochs, episodes and last test success; an older
    one (written without them) is read from the done.json beside it, else unknown."""
    from acder_lite.deploy.export import trained_of
    from acder_lite.io import load_torch
    from acder_lite.train.trainer import Trainer

    from conftest import rows_of, tiny_config

    run = tmp_path / "run"
    tr = Trainer(tiny_config(epochs=2), str(run))
    tr.train(False)
    src = str(run / "policy.pt")
    pol = load_torch(src)["policy"]
    last = rows_of(run / "progress.csv")[-1]
    want = dict(
        epochs=2.0, episodes=tr.episodes, test_success=float(last["test_success"])
    )
    assert want["episodes"] == 2 * 3 * 2  # epochs x cycles x 2 episodes a cycle
    assert trained_of(pol, src) == dict(want, **{"from": "the policy file"})
    meta = export_torchscript(pol, str(tmp_path / "p.ts"), src)
    assert meta["trained"] == trained_of(pol, src)
    older = {k: v for k, v in pol.items() if k != "trained"}
    from_done = trained_of(older, src)
    assert from_done["from"].startswith("done.json")
    assert {k: from_done[k] for k in want} == want
    assert trained_of(older, str(run)) == from_done  # the run folder itself
    assert trained_of(older, str(tmp_path / "policy.pt")) is None  # no run folder
    (run / "done.json").write_text("{}")
    assert trained_of(older, src) is None  # a done.json of another shape: not guessed


def test_cli(cli, tmp_path):
    from acder_lite.io import save_torch

    src = tmp_path / "policy.pt"
    save_torch(str(src), {"policy": policy_dict("FetchReach-v4", "simplified")})
    p = cli("export", str(src), "--out", str(tmp_path / "reach.ts"))
    assert p.returncode == 0, p.stderr
    assert p.stdout.startswith("export: ")
    assert "obs simplified: 5 observation entries" in p.stdout
    assert "how far its run had trained is not recorded" in p.stdout
    extra = {META_FILE: ""}
    torch.jit.load(str(tmp_path / "reach.ts"), _extra_files=extra)
    assert json.loads(extra[META_FILE])["env"] == "FetchReach-v4"
    one_line_error(
        cli("export", str(src), "--out", str(src)), "is the policy file itself"
    )


def test_onnx_same_actions(tmp_path):
    # requirements.txt pins onnx, onnxscript and onnxruntime: no skip, a broken install
    # fails here
    import onnxruntime as ort

    from acder_lite.deploy.export import export_onnx

    pol = policy_dict("FetchPush-v4", "simplified")
    export_onnx(pol, str(tmp_path / "p.onnx"))
    s = ort.InferenceSession(
        str(tmp_path / "p.onnx"), providers=["CPUExecutionProvider"]
    )
    o, g = inputs(11, 3)
    u = s.run(None, {"observation": o, "goal": g})[0]
    assert np.abs(u - Policy.from_state_dict(pol)(o, g)).max() <= 1e-6
    # the file documents its own inputs, as the TorchScript one does
    meta = json.loads(s.get_modelmeta().custom_metadata_map[META_FILE])
    assert meta["obs_names"][:3] == ["grip_pos.x", "grip_pos.y", "grip_pos.z"]
    assert len(meta["obs_names"]) == len(meta["obs_units"]) == 11
    assert meta["accepts"].startswith("observation: obs_names only")


def test_trained_text_counts_in_words():
    """'trained 1 epoch', not '1 epochs'; fractions and more are plural."""
    from acder_lite.deploy.export import trained_text

    one = trained_text(dict(epochs=1.0, episodes=1, test_success=None))
    assert one == "trained 1 epoch, 1 episode"
    assert trained_text(dict(epochs=2.5, episodes=1200, test_success=0.5)) == (
        "trained 2.5 epochs, 1,200 episodes, test success 0.50 at its last evaluation"
    )


def test_goals_are_clipped_to_clip_obs_before_normalising(tmp_path):
    """As `Policy.inputs`: a goal beyond clip_obs (200) is clipped, then normalised.
    With a goal normaliser about 100 wide, a goal of +-1000 reads as about +-2 (inside
    the norm clip 5), not as +-5: the export's actions are the policy's."""
    pol = policy_dict("FetchPush-v4", "full", spread=300.0)  # goal std ~ 100
    path = tmp_path / "p.ts"
    export_torchscript(pol, str(path))
    m = torch.jit.load(str(path))
    o, g = inputs(25, 3)
    g[:10], g[10:20] = 1000.0, -1000.0
    ref = Policy.from_state_dict(pol)
    x = ref.inputs(o, g).numpy()[:20, 25:]
    assert 1.5 < np.abs(x).min() and np.abs(x).max() < 2.5
    with torch.no_grad():
        got = m(torch.from_numpy(o), torch.from_numpy(g)).numpy()
    assert np.abs(got - ref(o, g)).max() <= 1e-6
