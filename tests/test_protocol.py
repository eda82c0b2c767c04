"""Protocol v2 (book/departures.md, "The protocol"): the task presets, Xavier init,
Baselines' clip, the stop
rule, and protocol-v1 configs read back as the runs they were."""

import csv
import glob
import json
import math
import os

import pytest
import torch

from acder_lite.config import METHODS, TASK_PRESETS, Config
from acder_lite.legacy import upgrade_legacy
from acder_lite.algo.core import mlp
from acder_lite.train.trainer import Trainer, target_clip

from conftest import ROOT, networks, tiny_config

V1 = os.path.join(ROOT, "experiments", "protocol-v1")


# ---- the task presets
@pytest.mark.parametrize(
    "env, epochs, cycles, threshold",
    [
        (
            "FetchReach-v4",
            25,
            10,
            1.0,
        ),  # Baselines' experiment/config.py: Reach epochs of 10 cycles
        ("FetchPush-v4", 50, 50, 0.95),
        ("FetchPickAndPlace-v4", 100, 50, 0.95),
    ],
)
def test_protocol_v2_defaults_per_task(env, epochs, cycles, threshold):
    cfg = Config(env=env, method="acder").resolve()
    assert (cfg.epochs, cfg.cycles, cfg.success_threshold) == (
        epochs,
        cycles,
        threshold,
    )
    assert (
        cfg.workers,
        cfg.episodes_per_cycle,
        cfg.updates_per_cycle,
        cfg.batch_size,
    ) == (4, 2, 40, 256)
    assert cfg.episodes_per_epoch == cycles * 2 * 4  # 80 on Reach, 400 elsewhere
    assert (
        cfg.test_episodes == 20
    )  # n_test_rollouts=10 x rollout_batch_size=2, per worker
    assert cfg.eval_every_cycles == 0  # one evaluation per epoch
    assert (
        cfg.buffer_scope == "worker" and cfg.buffer_capacity == 4_000_000
    )  # 10^6 per worker
    assert (cfg.init, cfg.target_clip, cfg.stop_patience, cfg.stop_gap_episodes) == (
        "xavier",
        "baselines",
        5,
        0,
    )
    # an epoch is W x 2 x cycles episodes: 400 on Push and Pick&Place, 80 on Reach
    assert cfg.workers * cfg.episodes_per_cycle * cfg.cycles == (
        80 if env == "FetchReach-v4" else 400
    )


@pytest.mark.parametrize("env", sorted(TASK_PRESETS))
def test_gamma_is_baselines_one_minus_one_over_the_horizon(env):
    """Baselines' experiment/config.py: gamma = 1 - 1/T, T the env's max_episode_steps;
    the critic's target clip [-1/(1-gamma), 0] follows (-50 at T = 50, -100 at 100)."""
    from acder_lite.envs.fetch import horizon

    T = horizon(env)  # the registered time limit
    cfg = Config(env=env, method="her").resolve()
    assert cfg.gamma == pytest.approx(1 - 1 / T, abs=1e-12)
    clip = target_clip(cfg.target_clip, cfg.switches, cfg.eta, cfg.gamma)
    assert clip[0] == pytest.approx(-T) and clip[1] == 0.0
    assert Config(env=env, gamma=0.9).resolve().gamma == 0.9  # an explicit value wins


def test_explicit_values_beat_the_presets():
    cfg = Config(
        env="FetchReach-v4", epochs=3, cycles=50, success_threshold=0.9
    ).resolve()
    assert (cfg.epochs, cfg.cycles, cfg.success_threshold) == (3, 50, 0.9)
    assert Config(buffer_scope="shared").resolve().buffer_capacity == 1_000_000
    assert Config(workers=2, buffer_size=5000).resolve().buffer_capacity == 10_000


@pytest.mark.parametrize(
    "scope, episodes", [("worker", 2 * 5000 // 50), ("shared", 5000 // 50)]
)
def test_the_trainer_allocates_the_buffer_capacity(scope, episodes):
    tr = Trainer(
        tiny_config(workers=2, buffer_size=5000, buffer_scope=scope)
    )  # Reach: T = 50
    assert tr.buffer.size == episodes


# ---- Xavier init (Baselines' her/util.py nn():
# tf.layers.dense with xavier_initializer, zero bias)
def _linears(module):
    return [m for m in module.modules() if isinstance(m, torch.nn.Linear)]


def _xavier_bound(layer):
    return math.sqrt(6.0 / (layer.in_features + layer.out_features))


def _uniform_on(w, bound) -> bool:
    """Weights drawn uniformly on [-bound, bound]: within it, reaching close to it, with
    the uniform's variance bound^2 / 3 (the three together tell Xavier's bound from
    torch's 1/sqrt(fan_in) on every layer shape here)."""
    w = w.detach()
    return (
        float(w.abs().max()) <= bound
        and float(w.abs().max()) > 0.95 * bound
        and float(w.std()) == pytest.approx(bound / math.sqrt(3), rel=0.1)
    )


def _is_xavier(layer) -> bool:
    return _uniform_on(layer.weight, _xavier_bound(layer)) and bool(
        (layer.bias == 0).all()
    )


def _is_torch_default(layer) -> bool:
    """nn.Linear's own init: Kaiming-uniform weights and uniform biases, both on
    1/sqrt(fan_in)."""
    bound = 1 / math.sqrt(layer.in_features)
    return (
        _uniform_on(layer.weight, bound)
        and float(layer.bias.detach().abs().max()) <= bound
        and bool((layer.bias != 0).any())
    )


def test_mlp_xavier_uniform_weights_and_zero_biases():
    torch.manual_seed(0)
    layers = _linears(mlp([31, 256, 256, 256, 4]))
    assert len(layers) == 4
    for layer in layers:
        assert _is_xavier(layer) and not _is_torch_default(layer)


def test_the_critic_sees_the_action_over_max_u_and_the_actor_scales_tanh():
    """Q(o, g, u) = MLP([x, u / max_u]) and pi = max_u * tanh(MLP(x)), checked with
    max_u = 2 (every Fetch task has max_u = 1, where u / max_u = u * max_u): the
    critic's value at u equals its network's at u / 2, and the actor's action is
    twice its network's tanh output."""
    from acder_lite.algo.core import Actor, Critic

    torch.manual_seed(0)
    x, u = torch.randn(5, 3), torch.rand(5, 2) * 4 - 2
    critic = Critic(3, 2, hidden=8, layers=1, max_u=2.0)
    want = critic.net(torch.cat([x, u / 2], -1)).squeeze(-1)
    torch.testing.assert_close(critic(x, u), want)
    actor = Actor(3, 2, hidden=8, layers=1, max_u=2.0)
    torch.testing.assert_close(actor(x), 2 * actor.net(x))


def test_torch_init_differs():
    torch.manual_seed(0)
    layers = _linears(mlp([31, 256, 256, 256, 4], init="torch"))
    assert all(_is_torch_default(layer) and not _is_xavier(layer) for layer in layers)
    # Kaiming-uniform's bound 1/sqrt(31) = 0.18 exceeds Xavier's sqrt(6/287) = 0.145
    first = layers[0]
    assert float(first.weight.detach().abs().max()) > _xavier_bound(first)


@pytest.mark.parametrize("init", ["xavier", "torch"])
def test_every_network_of_a_run_gets_its_init(init):
    tr = Trainer(tiny_config(method="acder", env="FetchPush-v4", init=init))
    nets = networks(tr)
    layers = [layer for net in nets for layer in _linears(net)]
    assert len(layers) >= 2 * len(nets)
    check = _is_xavier if init == "xavier" else _is_torch_default
    assert all(check(layer) for layer in layers)
    icm = Trainer(tiny_config(method="her-icm", init=init)).curiosity
    assert _linears(icm) and all(check(layer) for layer in _linears(icm))


# ---- the critic's target clip (Baselines' ddpg.py clip_pos_returns: [-1/(1-gamma), 0])
def test_baselines_clip_by_default_for_every_method_and_wide_on_request():
    assert Config().target_clip == "baselines"
    for method in METHODS:
        cfg = Config(env="FetchPush-v4", method=method).resolve()
        assert target_clip(
            cfg.target_clip, cfg.switches, cfg.eta, cfg.gamma
        ) == pytest.approx((-50.0, 0.0))
    tr = Trainer(tiny_config(method="acder", env="FetchReach-v4"))
    assert tr.clip_return == pytest.approx((-50.0, 0.0))
    wide = Trainer(tiny_config(method="acder", env="FetchReach-v4", target_clip="wide"))
    assert wide.clip_return == pytest.approx(
        (-1.5 * 50, 0.05 * 50)
    )  # Reach's eta = 0.05


def test_the_protocol_v1_method_name_is_acder_with_baselines_clip():
    cfg = Config.from_dict(
        dict(method="acder-baselines-clip", env="FetchPush-v4")
    ).resolve()
    assert (cfg.method, cfg.target_clip) == ("acder", "baselines")
    assert "acder-baselines-clip" not in METHODS


# ---- the stop rule: 5 consecutive epoch evaluations at the threshold, else the budget
def _scripted_run(tmp_path, script, **kw):
    cfg = tiny_config(
        epochs=len(script), cycles=1, **kw
    )  # Reach: threshold 1.0 by its preset
    tr = Trainer(cfg, str(tmp_path / "run"))
    scripted = iter(script)
    tr.evaluate = lambda: next(
        scripted
    )  # the test success by script; training itself runs as usual
    tr.train(False)
    done = json.loads((tmp_path / "run" / "done.json").read_text())
    with open(tmp_path / "run" / "progress.csv") as f:
        rows = list(csv.DictReader(f))
    return tr, done, rows


def test_success_held_for_five_epoch_evaluations_stops_the_run(tmp_path):
    tr, done, rows = _scripted_run(
        tmp_path, [0.9, 1.0, 1.0, 1.0, 1.0, 1.0, 0.5, 0.5, 0.5]
    )
    assert done["stop_reason"] == "success held" and done["stopped_early"]
    assert (
        done["epochs"] == 6 and done["episodes"] == 6 * 2
    )  # 1 cycle of 2 episodes an epoch
    assert [float(r["test_success"]) for r in rows] == [0.9, 1.0, 1.0, 1.0, 1.0, 1.0]
    assert done["stop_rule"] == dict(
        success_threshold=1.0, patience=5, budget_epochs=9, gap_episodes=0
    )


@pytest.mark.parametrize(
    "script, kw",
    [
        (
            [1.0, 1.0, 1.0, 1.0, 0.95, 1.0, 1.0, 1.0],
            {},
        ),  # never 5 in a row at 1.0 (Reach)
        (
            [0.96, 0.97, 0.99, 0.94, 0.95, 0.95, 0.99],
            dict(env="FetchPush-v4"),
        ),  # 0.94 breaks Push's 0.95
        ([1.0] * 6, dict(stop_patience=0)),  # 0: always the whole budget
    ],
)
def test_a_run_that_does_not_hold_the_threshold_runs_its_budget(tmp_path, script, kw):
    tr, done, rows = _scripted_run(tmp_path, script, **kw)
    assert done["stop_reason"] == "budget" and not done["stopped_early"]
    assert done["epochs"] == len(script) and len(rows) == len(script)


def test_the_threshold_is_held_on_push_at_095(tmp_path):
    _, done, _ = _scripted_run(
        tmp_path, [0.5, 0.95, 0.96, 1.0, 0.95, 0.97, 0.2], env="FetchPush-v4"
    )
    assert (done["stop_reason"], done["epochs"]) == ("success held", 6)
    assert done["stop_rule"]["success_threshold"] == 0.95


# ---- protocol-v1 configs (experiments/protocol-v1/*/*/seed*/config.json), read back
def _v1(env, method, seed=0):
    with open(os.path.join(V1, env, method, f"seed{seed}", "config.json")) as f:
        return json.load(f)["config"]


def test_upgrade_legacy_acder_baselines_clip():
    d = _v1("FetchPush-v4", "acder-baselines-clip")
    assert (
        d["method"] == "acder-baselines-clip" and d["stop_after_success"] == 0.95
    )  # as committed
    u = upgrade_legacy(d)
    assert "stop_after_success" in d and d["method"] == "acder-baselines-clip"  # a copy
    assert (u["method"], u["target_clip"]) == ("acder", "baselines")
    assert (u["init"], u["buffer_scope"], u["sicm_input"]) == (
        "torch",
        "shared",
        "normalised",
    )
    assert (u["success_threshold"], u["stop_patience"]) == (0.95, 10)
    assert "stop_after_success" not in u and "target_clip" not in u["switches"]
    cfg = Config.from_dict(d).resolve()
    assert (cfg.epochs, cfg.cycles, cfg.test_episodes, cfg.eval_every_cycles) == (
        50,
        50,
        10,
        5,
    )
    assert cfg.buffer_capacity == 1_000_000
    assert target_clip(
        cfg.target_clip, cfg.switches, cfg.eta, cfg.gamma
    ) == pytest.approx((-50.0, 0.0))


def test_upgrade_legacy_acder_had_the_wide_clip():
    d = _v1("FetchPush-v4", "acder")
    assert (
        "target_clip" not in d and "target_clip" not in d["switches"]
    )  # written before the switch
    cfg = Config.from_dict(d).resolve()
    assert (cfg.method, cfg.target_clip, cfg.init, cfg.buffer_scope) == (
        "acder",
        "wide",
        "torch",
        "shared",
    )
    assert target_clip(
        cfg.target_clip, cfg.switches, cfg.eta, cfg.gamma
    ) == pytest.approx((-75.0, 40.0))
    reach = Config.from_dict(_v1("FetchReach-v4", "acder")).resolve()
    assert (
        reach.epochs,
        reach.cycles,
        reach.success_threshold,
        reach.stop_patience,
    ) == (25, 50, 1.0, 5)


def test_every_committed_protocol_v1_config_reads_back():
    paths = sorted(glob.glob(os.path.join(V1, "*", "*", "seed*", "config.json")))
    assert len(paths) >= 30
    for path in paths:
        method_dir = path.split(os.sep)[-3]
        with open(path) as f:
            d = json.load(f)["config"]
        cfg = Config.from_dict(d).resolve()
        want_clip = "baselines" if method_dir == "acder-baselines-clip" else "wide"
        assert (cfg.target_clip, cfg.init, cfg.buffer_scope, cfg.sicm_input) == (
            want_clip,
            "torch",
            "shared",
            "normalised",
        ), path
        assert cfg.method in METHODS and cfg.test_episodes == 10 and cfg.cycles == 50, (
            path
        )
        assert (
            cfg.success_threshold == d["stop_after_success"]
            and cfg.stop_patience == d["stop_patience"]
        ), path
        # written before update_dtype existed: float32, whatever 'auto' would pick on
        # this CPU
        assert cfg.update_dtype == d.get("update_dtype", "float32"), path


def test_baselines_ddpg_defaults_reach_the_networks_and_normalisers():
    """book/departures.md, "The protocol" (v2): Baselines' defaults hold unless a row
    says otherwise: polyak 0.95 (the target moves 5% of the way to the main network a
    cycle), action L2 1.0, observations clipped to 200 and normalised with eps 0.01,
    clipped to 5, Adam lr 1e-3, noise 0.2, random actions 0.3, k = 4. Checked where
    they act: a
    trained run's normalisers clip at 5, its targets take a 0.05 step."""
    cfg = Config().resolve()
    assert (cfg.polyak, cfg.action_l2, cfg.clip_obs) == (0.95, 1.0, 200.0)
    assert (cfg.norm_eps, cfg.norm_clip, cfg.lr_actor, cfg.lr_critic) == (
        0.01,
        5.0,
        1e-3,
        1e-3,
    )
    assert (cfg.noise_eps, cfg.random_eps, cfg.replay_k) == (0.2, 0.3, 4)
    tr = Trainer(tiny_config())
    for norm in (tr.o_norm, tr.g_norm):
        assert (norm.eps, norm.clip) == (0.01, 5.0)
        assert norm.normalize(torch.full((1, norm.size), 1e6)).max().item() == 5.0
    agent = tr.agent
    with torch.no_grad():
        for net, targ in (
            (agent.actor, agent.actor_targ),
            (agent.critic, agent.critic_targ),
        ):
            for p, q in zip(net.parameters(), targ.parameters()):
                p.fill_(1.0)
                q.fill_(0.0)
    agent.update_targets()
    for targ in (agent.actor_targ, agent.critic_targ):
        for q in targ.parameters():
            torch.testing.assert_close(q, torch.full_like(q, 0.05))


def test_a_method_table_entry_names_only_switches_and_values_that_exist(monkeypatch):
    """The trainer builds what a METHODS entry names and nothing else, so a misspelt
    switch or value would train a run without that part, silently. Every entry of
    the table passes; each kind of slip is one line naming the entry and the switch."""
    from acder_lite import config as C

    assert all(C.switches_problem(m, sw) is None for m, sw in METHODS.items())
    her = dict(METHODS["her"])
    slips = {
        "curiosity": (dict(her, curiosity="rnd"), "'curiosity']='rnd' is not allowed"),
        "missing": (
            {k: v for k, v in her.items() if k != "priority"},
            "allowed: exactly",
        ),
        "extra": (dict(her, novelty=True), "allowed: exactly"),
        "type": (dict(her, goal_factor=1), "'goal_factor']=1 is not allowed"),
        "starts": (dict(her, start_states=True), "start_states without a curiosity"),
        "reward": (dict(her, curiosity_reward=True), "curiosity_reward without"),
    }
    for name, (sw, said) in slips.items():
        problem = C.switches_problem("mine", sw)
        assert problem and said in problem and "METHODS['mine']" in problem, name
    monkeypatch.setitem(METHODS, "mine", slips["curiosity"][0])
    with pytest.raises(C.ConfigError, match="is not allowed"):
        Config(env="FetchPush-v4", method="mine").resolve()
