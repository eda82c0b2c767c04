import os

import numpy as np
import torch
import pytest


from acder_lite.config import METHODS
from acder_lite.algo.rewards import goal_oriented_factor, shaped_reward
from acder_lite.train.trainer import Trainer, target_clip

from conftest import assert_same_run, rewards_of, rows_of, tiny_config


def test_same_seed_same_progress(tmp_path):
    for name in ("a", "b"):
        Trainer(
            tiny_config(method="acder", env="FetchPush-v4", epochs=2),
            str(tmp_path / name),
        ).train(False)
    a, b = (
        rows_of(tmp_path / "a" / "progress.csv"),
        rows_of(tmp_path / "b" / "progress.csv"),
    )
    assert len(a) == 2 and a == b
    c = tmp_path / "c"
    Trainer(
        tiny_config(method="acder", env="FetchPush-v4", epochs=2, seed=1), str(c)
    ).train(False)
    assert rows_of(c / "progress.csv") != a


def test_bfloat16_same_seed_same_progress(tmp_path):
    for name in ("a", "b"):
        Trainer(
            tiny_config(
                method="acder", env="FetchPush-v4", epochs=2, update_dtype="bfloat16"
            ),
            str(tmp_path / name),
        ).train(False)
    a, b = (
        rows_of(tmp_path / "a" / "progress.csv"),
        rows_of(tmp_path / "b" / "progress.csv"),
    )
    assert len(a) == 2 and a == b
    # float32 named: `auto` is bfloat16 itself where the update measured faster in it
    Trainer(
        tiny_config(
            method="acder", env="FetchPush-v4", epochs=2, update_dtype="float32"
        ),
        str(tmp_path / "f"),
    ).train(False)
    # float32 is another computation
    assert rows_of(tmp_path / "f" / "progress.csv") != a


@pytest.mark.parametrize(
    "method, threads, pause",
    [
        ("her", 1, 6),
        ("acder", 1, 6),
        ("her-per", 1, 6),
        ("acder", 2, 6),
        ("her-ebp", 1, 6),
        ("her-icm", 1, 6),
        ("ddpg", 1, 6),
        ("acder", 1, 5),
        ("her-per", 1, 5),
    ],
)
def test_resumed_run_equals_uninterrupted(tmp_path, method, threads, pause):
    """threads=2: the two losses at once and the envs in two threads, through a
    checkpoint too (the critic's frozen view follows the loaded weights).

    3 cycles an epoch, a row every 2 cycles and at each epoch's end: a pause after 6
    cycles is at a checkpoint; after 5 it falls mid-epoch, so the row of cycle 4,
    logged after the cycle-3 checkpoint, is dropped on resume and logged again. Equal
    at full precision (conftest.assert_same_run), not only to progress.csv's digits."""
    kw = dict(method=method, env="FetchPush-v4", eval_every_cycles=2, threads=threads)
    full = tmp_path / "full"
    whole = Trainer(tiny_config(epochs=4, **kw), str(full))
    whole.train(False)
    part = tmp_path / "part"
    Trainer(tiny_config(epochs=4, **kw), str(part)).train(False, max_cycles=pause)
    assert not (part / "done.json").exists()
    logged = [int(r["cycle"]) for r in rows_of(part / "progress.csv")]
    assert logged == {6: [2, 3, 4, 6], 5: [2, 3, 4]}[pause]
    from acder_lite.io import load_torch

    ckpt = load_torch(str(part / "checkpoint.pt"))
    cfg = tiny_config(epochs=4, **kw)
    tr = Trainer(cfg, str(part))
    tr.load_state_dict(ckpt)
    assert tr.cycle == pause // 3 * 3  # the last epoch's end
    assert [r["cycle"] for r in tr.rows] == logged[: 2 if pause == 5 else 4]
    tr.train(False)
    assert rows_of(part / "progress.csv") == rows_of(full / "progress.csv")
    assert_same_run(whole, tr)
    if method == "her-per":
        np.testing.assert_array_equal(whole.per.tree.tree, tr.per.tree.tree)
    if method == "her-ebp":
        np.testing.assert_array_equal(whole.ebp.energy, tr.ebp.energy)


def test_checkpoint_holds_buffer_and_rng(tmp_path):
    tr = Trainer(tiny_config(epochs=1), str(tmp_path))
    tr.train(False)
    from acder_lite.io import load_torch

    ck = load_torch(str(tmp_path / "checkpoint.pt"))
    assert ck["buffer"]["n"] == tr.buffer.n == 3 * 2
    np.testing.assert_array_equal(ck["buffer"]["state"], tr.buffer.state[: tr.buffer.n])
    assert set(ck["rng"]) == {"numpy", "torch", "envs", "test_envs"}
    # the values, not only the names: the streams as the run left them (the checkpoint
    # is the last thing an epoch does)
    import torch
    from acder_lite.envs.fetch import env_rng_state

    assert ck["rng"]["numpy"] == tr.rng.bit_generator.state
    assert torch.equal(ck["rng"]["torch"], torch.get_rng_state())
    assert ck["rng"]["envs"] == [env_rng_state(e) for e in tr.envs]
    assert ck["rng"]["test_envs"] == [env_rng_state(e) for e in tr.test_envs]
    # ... and not the seed's fresh streams
    assert ck["rng"]["numpy"] != np.random.default_rng(tr.cfg.seed).bit_generator.state
    assert os.path.getsize(tmp_path / "policy.pt") < os.path.getsize(
        tmp_path / "checkpoint.pt"
    )


@pytest.mark.parametrize("method", sorted(m for m in METHODS if m != "her-ebp"))
def test_every_method_runs_and_logs_its_diagnostics(tmp_path, method):
    tr = Trainer(
        tiny_config(method=method, env="FetchPush-v4", epochs=1), str(tmp_path)
    )
    rows = tr.train(False)
    header = open(tmp_path / "progress.csv").readline().strip().split(",")
    assert header[:6] == [
        "epoch",
        "cycle",
        "episodes",
        "env_steps",
        "test_success",
        "train_success",
    ]
    sw = METHODS[method]
    assert ("r_int_mean" in header) == (sw["curiosity"] != "none")
    assert ("alpha" in header) == sw["start_states"]
    assert ("lambda_mean" in header) == sw["goal_factor"]
    if sw["curiosity"] != "none":
        assert 0 < rows[-1]["r_int_mean"] <= tr.cfg.eta + 1e-6  # float32 clip
    if sw["goal_factor"]:
        # Eq. 6 on the relabelled rows: above 1 unless every action pointed at its goal
        assert 1.0 < rows[-1]["lambda_mean"] <= 1.5


def test_ebp_on_push_and_clip_range():
    """Also the trainer's EBP wiring: the energies of the stored episodes are
    `trajectory_energy` of their achieved goals with the env's dt (0.04 s on Push: 20
    MuJoCo substeps of 2 ms) and the config's weights and clip, the energy_mean column
    is their mean, and the minibatches' episodes follow the energies' probabilities."""
    from acder_lite.algo.priority import trajectory_energy

    tr = Trainer(tiny_config(method="her-ebp", env="FetchPush-v4", epochs=1))
    tr.train(False)
    assert tr.ebp is not None and tr.ebp.temperature is None  # exponent 1
    env = tr.envs[0].unwrapped
    assert tr.dt == env.dt == env.model.opt.timestep * env.n_substeps
    assert tr.dt == pytest.approx(0.04)
    n, c = tr.buffer.n, tr.cfg
    assert n == tr.ebp.n == 3 * 2  # epochs=1, cycles=3, 2 episodes a cycle
    energy = trajectory_energy(
        tr.buffer.ag[:n],
        tr.dt,
        w_potential=c.ebp_w_potential,
        w_kinetic=c.ebp_w_kinetic,
        clip_energy=c.ebp_clip_energy,
    )
    np.testing.assert_array_equal(tr.ebp.energy[:n], energy)
    (row,) = tr.rows  # one row: the epoch's six episodes
    assert row["energy_mean"] == pytest.approx(energy.mean(), rel=1e-12)
    p = tr.ebp.probabilities()
    assert p.max() > 0.5  # far from uniform (1/6): the frequencies below can tell
    tr.rng = np.random.default_rng(0)
    ep = np.concatenate([tr.sample_batch()["ep"] for _ in range(400)])  # 12,800 rows
    freq = np.bincount(ep, minlength=n) / ep.size
    np.testing.assert_allclose(freq, p, atol=0.015)  # sd <= 0.0045
    assert tr.clip_return == pytest.approx((-50.0, 0.0))
    theirs = Trainer(
        tiny_config(method="her-ebp", env="FetchPush-v4", epochs=1, ebp_temperature=1.0)
    )
    assert theirs.ebp.temperature == 1.0  # Zhao & Tresp's exponent 1/1.01
    acder = Trainer(tiny_config(method="acder", env="FetchPush-v4", epochs=1))
    # protocol v2: Baselines' clip for every method
    assert acder.clip_return == pytest.approx((-50.0, 0.0))
    wide = Trainer(
        tiny_config(method="acder", env="FetchPush-v4", epochs=1, target_clip="wide")
    )
    assert wide.clip_return == pytest.approx((-1.5 / 0.02, 0.8 / 0.02))


def test_per_wiring_priorities_weights_and_beta():
    """The trainer's PER wiring on one update, its minibatch drawn again from the
    saved random state: each sampled leaf ends up at (|td| + per_eps)^per_alpha of its
    row's TD error (a leaf sampled twice: the last row's), the importance weights are
    min_j p_j / p_i at beta = 1 (global max weight), and the critic loss is their
    weighted mean (w * td^2).mean(). per_beta (beta0 = 0.4, linear to 1 over the
    epochs * cycles = 6 cycles) is logged after cycles 3 and 6: 0.4 + 0.6 * 3/6 = 0.7
    and 0.4 + 0.6 * 6/6 = 1."""
    import torch

    tr = Trainer(tiny_config(method="her-per", env="FetchPush-v4"))  # 2 x 3 cycles
    rows = tr.train(False)
    assert [r["per_beta"] for r in rows] == pytest.approx([0.7, 1.0], abs=1e-12)
    assert tr.per_beta == 1.0
    c, T = tr.cfg, tr.T
    tree = tr.per.tree
    # sampling is stratified (one draw per 1/32 of the total): give leaf 0 half the
    # total so that it is drawn ~16 times, and "the last write wins" shows
    rest = tree.total() - tree.leaves()[0]
    tr.per.update(np.array([0]), np.array([0]), np.array([rest ** (1 / c.per_alpha)]))
    before = tree.leaves().copy()
    assert before[0] == pytest.approx(rest, rel=1e-9)
    state = tr.rng.bit_generator.state
    batch = tr.sample_batch()
    tr.rng.bit_generator.state = state
    out = tr.update_step()
    leaf = batch["ep"] * T + batch["t"]
    p = before[leaf]
    assert (p > 0).all() and len(np.unique(p)) > 1  # a mix of priorities
    np.testing.assert_allclose(
        batch["weights"], before[before > 0].min() / p, rtol=1e-6
    )
    td = out["td"].numpy().astype(np.float64)
    last = {int(k): i for i, k in enumerate(leaf)}  # the last row of each leaf
    # leaf 0 was sampled many times, with TD errors of their own (HER's goals differ)
    assert (leaf == 0).sum() > 10 and len(np.unique(td[leaf == 0])) > 1
    want = (np.abs(td[list(last.values())]) + c.per_eps) ** c.per_alpha
    np.testing.assert_allclose(tree.leaves()[list(last)], want, rtol=1e-12)
    # untouched leaves stay as they were
    other = np.setdiff1d(np.arange(tr.per.n_transitions), leaf)
    np.testing.assert_array_equal(tree.leaves()[other], before[other])
    w = torch.from_numpy(batch["weights"])
    assert float(w.min()) < 1.0
    weighted = float((w * out["td"] ** 2).mean())
    assert float(out["critic_loss"]) == pytest.approx(weighted, rel=1e-6)
    assert weighted != pytest.approx(float((out["td"] ** 2).mean()), rel=1e-3)


@pytest.mark.parametrize(
    "method, expected",
    [
        # rewards in {-1, 0}
        ("her", (-50.0, 0.0)),
        # lambda * r_her in [-1.5, 0], r_i in [0, 0.8]
        ("acder", (-75.0, 40.0)),
        ("acder-no-goal-factor", (-50.0, 40.0)),
        ("acder-no-curiosity", (-75.0, 0.0)),
        ("her-icm", (-50.0, 40.0)),
    ],
)
def test_target_clip_by_hand(method, expected):
    """The wide clip: the range the method's rewards can reach over 1 - gamma;
    gamma = 0.98, so 1 / (1 - gamma) = 50; eta = 0.8 (Push). Baselines' clip is
    [-50, 0] whatever the rewards."""
    assert target_clip("wide", METHODS[method], 0.8, 0.98) == pytest.approx(expected)
    assert target_clip("baselines", METHODS[method], 0.8, 0.98) == pytest.approx(
        (-50.0, 0.0)
    )


def test_wide_clip_moves_with_the_reward_bonus():
    """Rewards lambda * r_her + r_i + 0.25 on Push (eta = 0.8, gamma = 0.98): ACDER's in
    [0.25 - 1.5, 0.25 + 0.8], HER's in [0.25 - 1, 0.25], each over 1 - gamma = 0.02."""
    assert target_clip("wide", METHODS["acder"], 0.8, 0.98, 0.25) == pytest.approx(
        (-62.5, 52.5)
    )
    assert target_clip("wide", METHODS["her"], 0.8, 0.98, 0.25) == pytest.approx(
        (-37.5, 12.5)
    )
    assert target_clip("baselines", METHODS["her"], 0.8, 0.98, 0.25) == pytest.approx(
        (-50.0, 0.0)
    )


@pytest.mark.parametrize("method", ["her", "acder-no-curiosity", "her-icm"])
def test_reward_bonus_adds_its_constant_to_every_row(method):
    """The same minibatch, rewarded without and with `reward_bonus`: every row gains
    the constant, by hand on HER's {-1, 0} rewards (her: -0.75 or 0.25), beside the goal
    factor and beside ICM's r_i (the curiosity module's step is undone in between, so
    both calls see the same r_i)."""
    import copy

    tr = Trainer(tiny_config(method=method, env="FetchPush-v4", epochs=1))
    tr.train(False)
    batch = tr.sample_batch()
    tb = tr.batch_tensors(batch)
    cur = copy.deepcopy(tr.curiosity)
    plain = rewards_of(tr, batch, tb)
    tr.curiosity, tr.cfg.reward_bonus = cur, 0.25
    with_bonus = rewards_of(tr, batch, tb)
    np.testing.assert_allclose(with_bonus, plain + 0.25, rtol=0, atol=1e-6)
    if method == "her":
        assert set(np.unique(batch["r"])) == {-1.0, 0.0}
        np.testing.assert_array_equal(
            np.sort(np.unique(with_bonus)), np.float32([-0.75, 0.25])
        )


def test_baselines_clip_caps_the_critics_target_at_zero():
    # target_clip="baselines", the default
    tr = Trainer(tiny_config(method="acder", env="FetchPush-v4", epochs=1))
    tr.train(False)
    assert tr.clip_return == pytest.approx((-50.0, 0.0))
    batch = tr.sample_batch()
    tb = tr.batch_tensors(batch)
    tb["r"] = torch.from_numpy(rewards_of(tr, batch, tb))
    assert float(tb["r"].max()) > 0  # curiosity still pays where r_her = 0 ...
    from acder_lite.algo.ddpg import compute_loss_q

    with torch.no_grad():
        q_next = tr.agent.critic_targ(tb["x2"], tr.agent.actor_targ(tb["x2"]))
    _, td = compute_loss_q(
        tr.agent.critic,
        tr.agent.actor_targ,
        tr.agent.critic_targ,
        tb,
        tr.cfg.gamma,
        tr.clip_return,
    )
    with torch.no_grad():
        y = td + tr.agent.critic(tb["x"], tb["u"])
    assert float(y.max()) <= 1e-6  # ... but no target y exceeds 0
    np.testing.assert_allclose(
        y.numpy(), (tb["r"] + 0.98 * q_next).clamp(-50, 0).numpy(), atol=1e-5
    )


@pytest.mark.parametrize(
    "method", sorted(m for m, sw in METHODS.items() if sw["start_states"])
)
def test_start_states_are_used(method):
    """Once the pool holds candidates, episodes restart from stored states: in every
    method that has start states, the ablation without curiosity included (its S-ICM
    still ranks them).

    A lenient Reach (success within 15 cm instead of 5, for rewards and success alike)
    so that successful episodes, the only source of candidates, come within 24 untrained
    episodes."""
    tr = Trainer(tiny_config(method=method, env="FetchReach-v4", epochs=3, cycles=4))
    for env in tr.envs:  # tr.reward_fn is envs[0]'s compute_reward: it follows
        env.distance_threshold = 0.15
    tr.train(False)
    assert tr.buffer.success[: tr.buffer.n].any() and len(tr.selector.pool) > 0
    assert max(r["novel_start_share"] for r in tr.rows) > 0


def test_no_curiosity_keeps_r_int_out_of_the_reward():
    tr = Trainer(tiny_config(method="acder-no-curiosity", epochs=1, cycles=2))
    tr.train(False)
    assert tr.clip_return == pytest.approx((-50.0, 0.0))
    batch = tr.sample_batch()
    before = [p.detach().clone() for p in tr.curiosity.parameters()]
    r = rewards_of(tr, batch)
    # no r_int
    want, lam = shaped_reward(
        batch["r"], batch["her"], batch["o"][:, :3], batch["g"], batch["u"]
    )
    assert (lam > 1).any()  # the goal factor is on
    np.testing.assert_allclose(r, want, rtol=1e-6)
    # ... while S-ICM still trains on the minibatch (it ranks the start states)
    assert any(
        not bool((a == b).all()) for a, b in zip(before, tr.curiosity.parameters())
    )


@pytest.mark.parametrize("rows", ["relabelled", "all"])
def test_goal_factor_rows_picks_the_rows_lambda_applies_to(rows):
    """Config.goal_factor_rows (departure 12): Eq. 6 on the relabelled rows only, the
    others at lambda = 1; or on every row."""
    cfg = tiny_config(method="acder-no-curiosity", epochs=1, cycles=2)
    cfg.goal_factor_rows = rows
    tr = Trainer(cfg)
    tr.train(False)
    batch = tr.sample_batch()
    assert batch["her"].any() and not batch["her"].all()
    r = rewards_of(tr, batch)
    lam = goal_oriented_factor(batch["o"][:, :3], batch["g"], batch["u"])
    if rows == "relabelled":
        lam[~batch["her"]] = 1.0
    np.testing.assert_allclose(r, lam * batch["r"], rtol=1e-6)
    own = ~batch["her"] & (batch["r"] < 0)  # rows where the factor can show
    assert (lam[own] > 1).any() == (rows == "all")


@pytest.mark.parametrize(
    "gap,script,reason,episodes",
    [
        # first 0.95 at 4 episodes; epoch 2 ends at 12
        (7, [0.5, 0.96] + [0.9] * 30, "gap after first success", 12),
        # the gap rule off: the whole budget
        (0, [0.5, 0.96] + [0.9] * 30, "budget", 30),
        # held for stop_patience=2 first
        (7, [0.5, 0.96, 0.97] + [0.9] * 30, "success held", 6),
    ],
)
def test_stop_reasons(tmp_path, gap, script, reason, episodes):
    import json
    from acder_lite.runs import read as RU

    cfg = tiny_config(
        epochs=5,
        eval_every_cycles=1,
        success_threshold=0.95,
        stop_patience=2,
        stop_gap_episodes=gap,
    )
    tr = Trainer(cfg, str(tmp_path / "run"))
    scripted = iter(script)
    # test success by script; training itself runs as usual
    tr.evaluate = lambda: next(scripted)
    tr.train(False)
    done = json.loads((tmp_path / "run" / "done.json").read_text())
    assert (done["stop_reason"], done["episodes"]) == (reason, episodes)
    assert done["stopped_early"] == (reason != "budget")
    (run,) = RU.load_runs(tmp_path)
    assert (
        RU.how_ended(run)
        == {
            "gap after first success": "hovering",
            "budget": "full budget",
            "success held": "early stop",
        }[reason]
    )


@pytest.mark.parametrize(
    "method, sicm_input",
    [
        ("acder", "normalised"),
        ("acder", "raw"),
        ("acder-no-goal-factor", "normalised"),
        ("acder-no-curiosity", "normalised"),
        ("her-icm", "normalised"),
        ("her-icm", "raw"),  # ICM sees the normalised inputs whatever sicm_input
    ],
)
def test_the_reward_is_shaped_reward_plus_eq4_of_the_curiositys_prediction(
    method, sicm_input
):
    """On a fixed minibatch: Eq. 4 by hand of what the curiosity module predicts before
    its step (S-ICM: s' from s and a; ICM: phi(s') from phi(s) and a), then
    rewards.shaped_reward."""
    import torch

    tr = Trainer(
        tiny_config(method=method, env="FetchPush-v4", epochs=1, sicm_input=sicm_input)
    )
    tr.train(False)
    batch = tr.sample_batch()
    tb = tr.batch_tensors(batch)
    s, s2 = tr.curiosity_inputs(batch, tb)
    if method == "her-icm":
        assert s is tb["x"] and s2 is tb["x2"]
    with torch.no_grad():
        if method == "her-icm":
            m = tr.curiosity
            pred, target = (
                m.forward_model(torch.cat([m.phi(s), tb["u"]], -1)),
                m.phi(s2),
            )
        else:
            pred, target = tr.curiosity(s, tb["u"]), s2
    r_int = np.clip(
        0.5 * ((pred - target) ** 2).sum(-1).numpy().astype(np.float64), 0, tr.cfg.eta
    )
    sw = tr.cfg.switches
    want, _ = shaped_reward(
        batch["r"],
        batch["her"],
        batch["o"][:, :3],
        batch["g"],
        batch["u"],
        r_int.astype(np.float32) if sw["curiosity_reward"] else None,
        sw["goal_factor"],
    )
    r = rewards_of(tr, batch, tb)
    np.testing.assert_allclose(r, want, rtol=1e-5, atol=1e-6)
    if sw["curiosity_reward"]:
        assert (r_int > 0).all() and not np.allclose(r, batch["r"])


def test_curiosity_inputs_normalised_or_raw():
    """S-ICM sees the policy's normalised (o, g) with 'normalised'; 'raw' (the
    default) gives (o, g) clipped to clip_obs only, the row's goal in s and s' alike."""
    import torch

    runs = {
        k: Trainer(
            tiny_config(method="acder", env="FetchPush-v4", epochs=1, sicm_input=k)
        )
        for k in ("normalised", "raw")
    }
    for tr in runs.values():
        tr.train(False)
    tr = runs["normalised"]
    batch = tr.sample_batch()
    tb = tr.batch_tensors(batch)
    s, s2 = tr.curiosity_inputs(batch, tb)
    assert s is tb["x"] and s2 is tb["x2"]
    o_n = tr.o_norm.normalize(np.clip(batch["o"], -200, 200))
    g_n = tr.g_norm.normalize(np.clip(batch["g"], -200, 200))
    np.testing.assert_allclose(
        s.numpy(), np.concatenate([o_n, g_n], 1), rtol=1e-4, atol=1e-4
    )
    tr = runs["raw"]
    batch = tr.sample_batch()
    s, s2 = tr.curiosity_inputs(batch, tr.batch_tensors(batch))
    np.testing.assert_allclose(
        s.numpy(), np.concatenate([batch["o"], batch["g"]], 1), rtol=1e-6
    )
    np.testing.assert_allclose(
        s2.numpy(), np.concatenate([batch["o2"], batch["g"]], 1), rtol=1e-6
    )
    assert s.dtype == torch.float32 and not np.allclose(
        s.numpy(), tr.batch_tensors(batch)["x"].numpy()
    )
    batch["o"] = batch["o"] + 1e3  # beyond clip_obs = 200: clipped, not normalised
    s, _ = tr.curiosity_inputs(batch, tr.batch_tensors(batch))
    assert float(s[:, : tr.dims["o"]].max()) == 200.0


def test_sicm_angles_sincos_is_what_sicm_sees_and_trains_on():
    """`sicm_angles="sincos"`: S-ICM's s and s' are the raw (o, g) with the block's
    three Euler angles (11-13) as their sines and cosines, 3 columns wider; the model is
    built for that width and Eq. 4's reward is taken of it. The policy's inputs are
    unchanged."""
    from acder_lite.envs.observations import sincos_angles

    runs = {
        k: Trainer(tiny_config(method="acder", env="FetchPush-v4", sicm_angles=k))
        for k in ("euler", "sincos")
    }
    for tr in runs.values():
        tr.train(False)
    euler, tr = runs["euler"], runs["sincos"]
    assert euler.sicm_angles is None and tr.sicm_angles.tolist() == [11, 12, 13]
    batch = tr.sample_batch()
    tb = tr.batch_tensors(batch)
    assert tb["x"].shape[1] == euler.batch_tensors(batch)["x"].shape[1] == 28
    s, s2 = tr.curiosity_inputs(batch, tb)
    assert s.shape[1] == s2.shape[1] == 31 == tr.curiosity.net[0].in_features - 4
    for got, o in ((s, batch["o"]), (s2, batch["o2"])):
        want = np.concatenate([sincos_angles(o, tr.sicm_angles), batch["g"]], 1)
        np.testing.assert_allclose(got.numpy(), want, rtol=1e-6, atol=1e-7)
    assert np.abs(s[:, 22:28].numpy()).max() <= 1.0  # sines (22-24), cosines (25-27)
    r = rewards_of(tr, batch, tb)
    assert np.isfinite(r).all() and tr.rows and np.isfinite(tr.rows[-1]["r_int_mean"])


def test_candidate_success_reads_the_last_step_or_any_step():
    """Config.candidate_success (departure 16): an episode whose gripper reaches the
    goal at step 2 only is a success for 'any', not for 'final'; one that ends on it is
    both."""
    tr = Trainer(tiny_config(method="acder", epochs=1, cycles=1))
    tr.train(False)
    buf, T = tr.buffer, tr.T
    far = buf.g[:2] + 1.0  # 1 m from the goal on each axis: no step succeeds
    buf.ag[:2, 1:] = far
    buf.ag[0, 3] = buf.g[0, 2]  # episode 0: on the goal after step 2 only
    buf.ag[1, T] = buf.g[1, T - 1]  # episode 1: on the goal after its last step
    buf.success[:2] = [False, True]  # as the rollout records them (the last step)
    ep = np.array([0, 1, 1, 0])
    want = {"final": [False, True, True, False], "any": [True, True, True, True]}
    for rule in ("final", "any"):
        tr.cfg.candidate_success = rule
        assert tr.episode_success(ep).tolist() == want[rule]


def test_explore_act_is_baselines_noise_then_random_actions():
    """Trainer.explore_act (chapter 2): without noise or random actions it is the
    policy's action; with random_eps = 1 every action is uniform in [-max_u, max_u] and
    does not depend on the policy; Gaussian noise on a saturated policy is clipped to
    max_u exactly; a share random_eps of the rows is random."""
    import torch

    def acts(**kw):
        tr = Trainer(tiny_config(env="FetchPush-v4", **kw))
        obs = tr.envs[0]._get_obs()
        o = np.repeat(obs["observation"][None], 4000, 0)
        g = np.repeat(obs["desired_goal"][None], 4000, 0)
        return tr, o, g

    tr, o, g = acts(noise_eps=0.0, random_eps=0.0)
    np.testing.assert_array_equal(tr.explore_act(o, g), tr.policy(o, g))
    tr, o, g = acts(random_eps=1.0)
    state = tr.rng.bit_generator.state
    u = tr.explore_act(o, g)
    with torch.no_grad():
        tr.policy.actor.net[-2].bias.fill_(100.0)  # another policy, saturated
    tr.rng.bit_generator.state = state
    np.testing.assert_array_equal(tr.explore_act(o, g), u)
    assert np.abs(u).max() <= tr.max_u and u.std() > 0.5  # uniform on [-1, 1]: 0.577
    tr.cfg.random_eps = 0.0
    u = tr.explore_act(o, g)  # tanh(100) = 1 plus noise, clipped
    assert u.max() == tr.max_u and (u == tr.max_u).mean() > 0.4  # half the noise > 0
    tr, o, g = acts(noise_eps=0.0)  # Baselines' random_eps = 0.3
    random_rows = (tr.explore_act(o, g) != tr.policy(o, g)).any(1)
    assert 0.27 < random_rows.mean() < 0.33  # 0.3, sd 0.007 over 4,000 rows


def test_eq9_follows_the_latest_test_success(monkeypatch):
    """Each evaluation's test success sets alpha (Eq. 9, alpha0 = 0.8, base 10e): 0
    gives 0.8 - 0.5 / 27.18282 = 0.78161, 1 gives 0.3, 0.5 gives 0.8 - 0.5 / 5.21371 =
    0.70410; the alpha column logs the value the next cycles draw with."""
    tr = Trainer(
        tiny_config(env="FetchPush-v4", method="acder", epochs=1, eval_every_cycles=1)
    )
    said = iter([0.0, 1.0, 0.5])

    def scripted():
        tr.diag["q_mean"] = 0.0
        return next(said)

    monkeypatch.setattr(tr, "evaluate", scripted)
    rows = tr.train(False)
    assert [r["test_success"] for r in rows] == [0.0, 1.0, 0.5]
    np.testing.assert_allclose(
        [r["alpha"] for r in rows], [0.78161, 0.3, 0.70410], atol=5e-6
    )
    assert tr.selector.alpha == pytest.approx(0.70410, abs=5e-6)


def test_goal_factor_measures_from_the_gripper_not_the_block():
    """Eq. 6's s^a_t is the gripper position, o[:3] (book/departures.md, departure 10),
    not the achieved goal (on Push, the block). A minibatch set by hand on FetchPush:
    gripper at the origin, block at x = 1, relabelled goal g^h at x = 0.5, r_her = -1
    on every row, actions +x and -x in turn. From the gripper the goal lies along +x:
    lambda = 1 and 1.5, so r = -1, -1.5, ... (Eq. 5); measured from the block it lies
    along -x and the two
    swap. S-ICM's r_i stays out of the reward (acder-no-curiosity)."""
    tr = Trainer(tiny_config(method="acder-no-curiosity", env="FetchPush-v4", epochs=1))
    tr.collect()
    batch = tr.sample_batch()
    n = len(batch["r"])
    batch["o"] = batch["o"].copy()
    batch["o"][:, :3] = 0.0
    batch["ag"] = np.tile(np.float32([1.0, 0.0, 0.0]), (n, 1))
    batch["g"] = np.tile(np.float32([0.5, 0.0, 0.0]), (n, 1))
    batch["her"] = np.ones(n, bool)
    batch["r"] = np.full(n, -1.0, np.float32)
    batch["u"] = np.zeros_like(batch["u"])
    batch["u"][:, 0] = np.where(np.arange(n) % 2 == 0, 1.0, -1.0)
    r = rewards_of(tr, batch)
    np.testing.assert_allclose(r, np.where(np.arange(n) % 2 == 0, -1.0, -1.5))


def test_normalisers_are_fitted_on_her_relabelled_clipped_samples():
    """Baselines fits the normalisers on HER-relabelled transitions of the episodes just
    collected, clipped to clip_obs (book/departures.md, departure 2), not on the stored
    desired goals. Four hand-made Reach episodes: o = 500 everywhere (clipped to 200),
    desired goal 5, achieved goal 0. With future_p = 0.8 a share ~0.2 of the n*T = 200
    samples keeps goal 5, the rest get 0: the goal mean is ~1.0 (sd 5 * sqrt(0.16 / 200)
    = 0.14), not 5; the observation mean is exactly 200. (`update_normalizers` is the
    step
    `collect` takes; called here on episodes whose goals are known.)"""
    tr = Trainer(tiny_config(method="her"))
    n, T, d = 4, tr.T, tr.dims
    ep = dict(
        o=np.full((n, T + 1, d["o"]), 500.0, np.float32),
        ag=np.zeros((n, T + 1, d["g"]), np.float32),
        g=np.full((n, T, d["g"]), 5.0, np.float32),
        u=np.zeros((n, T, d["u"]), np.float32),
    )
    tr.update_normalizers(ep)
    assert tr.o_norm.count == tr.g_norm.count == n * T
    np.testing.assert_allclose(tr.o_norm.mean, 200.0)
    assert np.all(np.abs(tr.g_norm.mean - 1.0) < 0.6)
    assert np.all(tr.g_norm.mean == tr.g_norm.mean[0])  # a row keeps or loses all 3


@pytest.mark.parametrize("restart_goal", ["episode", "resample"])
def test_a_restarted_episode_keeps_or_resamples_its_goal(restart_goal):
    """Config.restart_goal: an episode restarted from a stored candidate pursues the
    candidate's goal with 'episode', and with 'resample' (the default) the goal its
    env's reset drew, never the stored one."""
    from acder_lite.envs import fetch as E

    tr = Trainer(tiny_config(method="acder", restart_goal=restart_goal))
    env = tr.envs[0]
    stored = np.array([1.25, 0.65, 0.55])  # a goal of our own: no reset draws it
    tr.selector.pool.append(dict(state=E.get_state(env), goal=stored, r_int=0.0))
    tr.selector.alpha = 1.0  # every episode restarts from the pool
    ep = tr.collect()
    assert ep["novel"].all()
    np.testing.assert_array_equal(ep["g"][0, 0], env.goal.astype(np.float32))
    if restart_goal == "episode":
        np.testing.assert_array_equal(
            ep["g"][0], np.tile(stored.astype(np.float32), (tr.T, 1))
        )
    else:
        assert np.abs(ep["g"][0, 0] - stored).max() > 1e-3


def test_a_resumed_run_keeps_counting_its_wall_time(tmp_path):
    """wall_s is the run's training time across resumes: a resumed trainer starts from
    its checkpoint's wall time, so progress.csv's wall_s never falls and done.json's
    covers both stretches."""
    import csv
    import json

    from acder_lite.io import load_torch

    cfg = tiny_config(epochs=2, stop_patience=0)
    run = tmp_path / "run"
    Trainer(cfg, str(run)).train(False, max_cycles=3)
    ckpt = load_torch(str(run / "checkpoint.pt"))
    before = ckpt["progress"]["wall"]
    assert before > 0
    tr = Trainer(cfg, str(run))
    tr.load_state_dict(ckpt)
    assert tr.wall == before
    tr.train(False)
    with open(run / "progress.csv") as f:
        walls = [float(r["wall_s"]) for r in csv.DictReader(f)]
    assert len(walls) == 2 and walls[0] <= before < walls[1]
    done = json.loads((run / "done.json").read_text())
    assert done["wall_s"] == tr.wall > before


def test_resuming_drops_the_rows_logged_after_the_checkpoint(tmp_path):
    """Rows evaluated after the last checkpoint (mid-epoch evaluations of a run then
    interrupted) are no part of the resumed run: resuming rewrites progress.csv to the
    checkpoint's rows before it trains on."""
    from acder_lite.io import load_torch

    cfg = tiny_config(epochs=2, cycles=3, eval_every_cycles=1, stop_patience=0)
    run = tmp_path / "run"
    Trainer(cfg, str(run)).train(False, max_cycles=5)  # checkpoint at cycle 3
    cycles = lambda: [r["cycle"] for r in rows_of(run / "progress.csv")]  # noqa: E731
    assert cycles() == ["1", "2", "3", "4", "5"]
    tr = Trainer(cfg, str(run))
    tr.load_state_dict(load_torch(str(run / "checkpoint.pt")))
    tr.train(False, max_cycles=3)  # resumed, and paused before a cycle more
    assert cycles() == ["1", "2", "3"]


def test_config_json_names_the_commit_and_whether_the_source_had_changes(
    monkeypatch,
):
    """`versions()["git"]`: the commit git names, '+dirty' after it only when git
    status lists a changed file, and '' outside a checkout (no commit, or no git)."""
    import subprocess
    import types

    from acder_lite.runs import runfiles

    def git(head, status):
        def run(cmd, **kw):
            out = head if cmd[1] == "rev-parse" else status
            return types.SimpleNamespace(stdout=out)

        monkeypatch.setattr(subprocess, "run", run)
        return runfiles.git_commit()

    assert git("abc123\n", "") == "abc123"
    assert git("abc123\n", " M acder_lite/train/trainer.py\n") == "abc123+dirty"
    assert git("", " M acder_lite/train/trainer.py\n") == ""

    def no_git(cmd, **kw):
        raise FileNotFoundError("git")

    monkeypatch.setattr(subprocess, "run", no_git)
    assert runfiles.git_commit() == ""


def test_a_resumed_config_json_holds_the_new_config_and_the_first_command(tmp_path):
    """A resume at cycle 5 with --epochs 4: config.json's config becomes the resumed
    one, its command stays the first, and the resume's command and cycle are appended
    under "resumes"."""
    import json

    from acder_lite.runs.runfiles import RunFiles

    rf = RunFiles(str(tmp_path))
    rf.write_config({"epochs": 2}, 7, "train --out run", 0)
    rf.write_config({"epochs": 4}, 7, "train --resume run --epochs 4", 5)
    d = json.loads((tmp_path / "config.json").read_text())
    assert d["config"] == {"epochs": 4} and d["seed"] == 7
    assert d["command"] == "train --out run"
    assert [(r["command"], r["at_cycle"]) for r in d["resumes"]] == [
        ("train --resume run --epochs 4", 5)
    ]


def test_a_cycle_updates_the_targets_once_after_its_updates(monkeypatch):
    """Baselines' cycle: episodes_per_cycle (2) collections, updates_per_cycle (4)
    gradient steps, then one Polyak step of the target networks (not one per
    update), and the cycle counter moves by one."""
    tr = Trainer(tiny_config())
    calls = []
    monkeypatch.setattr(tr, "collect", lambda: calls.append("collect"))
    monkeypatch.setattr(tr, "update_step", lambda: calls.append("update"))
    monkeypatch.setattr(tr.agent, "update_targets", lambda: calls.append("targets"))
    tr.train_cycle()
    assert calls == ["collect"] * 2 + ["update"] * 4 + ["targets"]
    assert tr.cycle == 1


def test_log_row_averages_each_column_over_its_own_count(monkeypatch):
    """log_row by hand, after cycle 4 of 3-cycle epochs (a mid-epoch evaluation,
    epoch 4/3) with the diagnostics of 2 updates and 4 episodes: the losses, r_i,
    the curiosity loss and lambda are sums over the updates (critic 3.0 -> 1.5, actor
    -1.0 -> -0.5, r_i 0.5 -> 0.25, loss 0.25 -> 0.125, lambda 2.5 -> 1.25), the
    success and novel-start counts are over the episodes (1 of 4 -> 0.25, 2 of 4 ->
    0.5); q_mean is the evaluation's. The diagnostics start again from zero."""
    tr = Trainer(tiny_config(method="acder"))
    tr.cycle, tr.episodes, tr.env_steps = 4, 8, 400

    def scripted():
        tr.diag["q_mean"] = -2.0
        return 0.75

    monkeypatch.setattr(tr, "evaluate", scripted)
    tr.diag.update(
        n_upd=2,
        critic_loss=3.0,
        actor_loss=-1.0,
        r_int=0.5,
        cur_loss=0.25,
        lam=2.5,
        n_ep=4,
        n_succ=1,
        n_novel=2,
    )
    row = tr.log_row(0.0)
    assert row["epoch"] == pytest.approx(4 / 3)
    want = dict(
        cycle=4,
        episodes=8,
        env_steps=400,
        test_success=0.75,
        train_success=0.25,
        critic_loss=1.5,
        actor_loss=-0.5,
        q_mean=-2.0,
        r_int_mean=0.25,
        curiosity_loss=0.125,
        lambda_mean=1.25,
        novel_start_share=0.5,
    )
    assert {k: row[k] for k in want} == want
    assert tr.rows == [row] and tr.diag["n_upd"] == tr.diag["n_ep"] == 0


def test_lambda_mean_sums_each_minibatchs_mean_factor():
    """The lambda_mean column's sum: each reward computation adds the mean of Eq. 6's
    factor over its minibatch (lambda = 1 on rows HER did not relabel), not its
    largest value."""
    tr = Trainer(tiny_config(method="acder-no-curiosity", env="FetchPush-v4"))
    tr.collect()
    batch = tr.sample_batch()
    lam = goal_oriented_factor(batch["o"][:, :3], batch["g"], batch["u"])
    lam[~batch["her"]] = 1.0
    assert lam.max() > lam.mean() > 1.0
    rewards_of(tr, batch)
    assert tr.diag["lam"] == pytest.approx(lam.mean(), rel=1e-6)


def test_q_mean_is_the_critic_at_the_test_episodes_first_states(monkeypatch):
    """evaluate's q_mean: Q(s_0, pi(s_0)) at the first state of every test episode
    (2 rounds of the worker's test env), averaged; the success is the mean of their
    last steps' flags."""
    import torch

    from acder_lite.train import trainer as trainer_module

    tr = Trainer(tiny_config(env="FetchPush-v4", test_episodes=2))
    real, eps = trainer_module.run_episodes, []

    def recorded(*a, **kw):
        eps.append(real(*a, **kw))
        return eps[-1]

    monkeypatch.setattr(trainer_module, "run_episodes", recorded)
    success = tr.evaluate()
    assert len(eps) == 2
    with torch.no_grad():
        q = [
            tr.agent.critic(x, tr.agent.actor(x)).numpy()
            for x in (tr.policy.inputs(e["o"][:, 0], e["g"][:, 0]) for e in eps)
        ]
    assert tr.diag["q_mean"] == pytest.approx(float(np.mean(q)), rel=1e-6)
    assert success == np.mean([e["success"] for e in eps])


def test_should_stop_once_the_last_patience_rows_hold_the_threshold():
    """The stop rule with stop_patience = 2 and threshold 0.95: not after one row
    (too few), as soon as the first two both hold it, not when the latest of three
    falls below it, and again when the last two hold it (an earlier miss no longer
    counts)."""
    tr = Trainer(tiny_config(success_threshold=0.95, stop_patience=2))

    def stop(*successes):
        tr.rows = [dict(test_success=s) for s in successes]
        return tr.should_stop()

    assert not stop(0.96)
    assert stop(0.96, 0.95)
    assert not stop(0.96, 0.97, 0.9)
    assert stop(0.5, 0.9, 0.96, 1.0)
    tr.cfg.stop_patience = 0
    assert not stop(1.0, 1.0)


def test_past_gap_counts_from_the_first_success_inclusive():
    """The gap rule (stop_gap_episodes = 6): the first evaluation at 0.95 or more
    logged 4 episodes; the run is past the gap at 4 + 6 = 10 episodes exactly, not
    at 9, and never without a success."""
    tr = Trainer(tiny_config(success_threshold=0.95, stop_gap_episodes=6))
    tr.rows = [
        dict(episodes=2, test_success=0.5),
        dict(episodes=4, test_success=0.96),
        dict(episodes=6, test_success=0.9),
    ]
    tr.episodes = 9
    assert not tr.past_gap()
    tr.episodes = 10
    assert tr.past_gap()
    tr.rows[1]["test_success"] = 0.9
    assert not tr.past_gap()


def test_a_loaded_checkpoint_keeps_its_stop_reason():
    """state_dict / load_state_dict carry the end of a finished run: done and its
    stop_reason (done.json's, should the run be resumed again)."""
    tr = Trainer(tiny_config())
    tr.done, tr.stop_reason = True, "gap after first success"
    new = Trainer(tiny_config())
    new.load_state_dict(tr.state_dict())
    assert (new.done, new.stop_reason) == (True, "gap after first success")


def test_collect_counts_episodes_and_env_steps():
    """One collection on Reach (T = 50 steps) with 2 workers: 2 episodes and 2 * 50 =
    100 env steps (T actions an episode; its T + 1 observations include the reset's),
    both episodes in the buffer and in the diagnostics' episode count."""
    tr = Trainer(tiny_config(workers=2))
    assert tr.T == 50
    tr.collect()
    assert (tr.episodes, tr.env_steps, tr.buffer.n, tr.diag["n_ep"]) == (2, 100, 2, 2)


def test_a_run_stopped_mid_epoch_saves_its_last_state(tmp_path):
    """The stop rule can end a run between epoch ends (eval_every_cycles = 1): success
    held once (stop_patience = 1) at the evaluation after cycle 2 of a 3-cycle epoch.
    The checkpoint and policy.pt are then those of cycle 2, the run's last state, not
    of the start; done.json's wall time is the checkpoint's."""
    import json

    from acder_lite.io import load_torch

    cfg = tiny_config(
        epochs=2, eval_every_cycles=1, stop_patience=1, success_threshold=0.5
    )
    tr = Trainer(cfg, str(tmp_path))
    scripted = iter([0.0, 1.0])
    tr.evaluate = lambda: next(scripted)
    tr.train(False)
    assert (tr.cycle, tr.stop_reason) == (2, "success held")
    ck = load_torch(str(tmp_path / "checkpoint.pt"))
    assert ck["progress"]["cycle"] == 2 and ck["progress"]["done"]
    pol = load_torch(str(tmp_path / "policy.pt"))
    assert pol["policy"]["trained"]["epochs"] == pytest.approx(2 / 3)
    done = json.loads((tmp_path / "done.json").read_text())
    assert done["wall_s"] == ck["progress"]["wall"] > 0
