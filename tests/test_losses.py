"""The DDPG losses on a fixed batch, with networks set to constants so the
values are known."""

import numpy as np
import pytest
import torch

from acder_lite.algo.core import Actor, Critic
from acder_lite.algo.curiosity import ICM, SICM
from acder_lite.algo.ddpg import compute_loss_pi, compute_loss_q


def const_critic(c):
    q = Critic(3, 2, hidden=4, layers=1)
    for p in q.parameters():
        torch.nn.init.zeros_(p)
    q.net[-1].bias.data.fill_(c)
    return q


def const_actor(b):
    a = Actor(3, 2, hidden=4, layers=1)
    for p in a.parameters():
        torch.nn.init.zeros_(p)
    a.net[-2].bias.data.fill_(b)  # output = tanh(b)
    return a


def batch():
    return dict(
        x=torch.randn(4, 3),
        x2=torch.randn(4, 3),
        u=torch.rand(4, 2),
        r=torch.tensor([-1.0, 0.0, -1.0, -1.0]),
    )


def test_loss_q_by_hand():
    b = batch()
    # Q = 2, Q' = -10: y = r + 0.98 * -10 = [-10.8, -9.8, -10.8, -10.8]; (y - 2)^2 mean
    loss, td = compute_loss_q(
        const_critic(2.0), const_actor(0.3), const_critic(-10.0), b, 0.98, (-50.0, 0.0)
    )
    y = np.array([-10.8, -9.8, -10.8, -10.8])
    assert loss.item() == pytest.approx(np.mean((y - 2) ** 2), rel=1e-6)
    np.testing.assert_allclose(td.numpy(), y - 2, rtol=1e-6)


def test_loss_q_target_clip_and_weights():
    b = batch()
    # Q' = -100: y = r - 98 clipped to -1/(1-0.98) = -50; Q = 0
    loss, _ = compute_loss_q(
        const_critic(0.0), const_actor(0.0), const_critic(-100.0), b, 0.98, (-50.0, 0.0)
    )
    assert loss.item() == pytest.approx(2500.0)
    # the same with weights: y = r - 98 = [-99, -98, -99, -99] clips to -50 on every
    # row, each squared error 2500; the loss is mean_i w_i (y_i - Q_i)^2
    w = torch.tensor([1.0, 0.0, 0.5, 0.5])
    loss, td = compute_loss_q(
        const_critic(0.0),
        const_actor(0.0),
        const_critic(-100.0),
        b,
        0.98,
        (-50.0, 0.0),
        w,
    )
    assert td.tolist() == [-50.0] * 4
    assert loss.item() == pytest.approx(2500.0 * (1.0 + 0.0 + 0.5 + 0.5) / 4)  # 1250
    assert loss.item() == pytest.approx(1250.0)
    # Q' = +10 with the upper clip 0: y = r + 9.8 clipped to 0 on every row; Q = 1
    loss, _ = compute_loss_q(
        const_critic(1.0),
        const_actor(0.0),
        const_critic(10.0),
        b,
        0.98,
        (-50.0, 0.0),
        w,
    )
    assert loss.item() == pytest.approx((1.0 * 1 + 0 + 0.5 * 1 + 0.5 * 1) / 4)


def test_loss_pi_by_hand():
    b = batch()
    # Q = 3 everywhere, pi = tanh(0.5) in both dims: loss = -3 + 1.0 * tanh(0.5)^2
    loss = compute_loss_pi(const_actor(0.5), const_critic(3.0), b, action_l2=1.0)
    assert loss.item() == pytest.approx(-3 + np.tanh(0.5) ** 2, rel=1e-6)


def test_loss_pi_reads_the_critic_at_the_actors_action():
    """Eq. 3 with a critic that sees its action: Q(s, u) = u_1 + u_2 and pi = max_u
    tanh(0.5) in both dims, so -mean Q = -2 max_u tanh(0.5) and the penalty on
    pi / max_u is tanh(0.5)^2 whatever max_u: -0.71068 at max_u = 1, -1.63492 at 2. A
    loss that read the stored actions `u` instead, or forgot to divide by max_u,
    gives other numbers."""
    b = batch()
    for max_u, want in ((1.0, -0.71068), (2.0, -1.63492)):
        actor = const_actor(0.5)
        actor.max_u = max_u
        loss = compute_loss_pi(actor, lambda x, u: u.sum(-1), b, action_l2=1.0)
        assert loss.item() == pytest.approx(want, abs=1e-5)


def test_loss_q_reads_the_next_state_and_the_target_actor():
    """Eq. 2 with a target critic that sees its inputs: Q'(s', u') = s'_1 + u'_1 +
    u'_2, the target actor's u' = (0.25, 0.25), s'_1 = 0, -1, -2, -3 and s = 0: y = r +
    0.98 (s'_1 + 0.5) = -0.51, -0.49, -2.47, -3.45; Q = 2, so td = y - 2. A target read
    at s instead of s', or at the stored action, gives other numbers."""
    b = batch()
    b["x"] = torch.zeros(4, 3)
    b["x2"][:, 0] = torch.tensor([0.0, -1.0, -2.0, -3.0])
    loss, td = compute_loss_q(
        const_critic(2.0),
        lambda x: torch.full((len(x), 2), 0.25),
        lambda x, u: x[:, 0] + u.sum(-1),
        b,
        0.98,
        (-50.0, 0.0),
    )
    y = np.array([-0.51, -0.49, -2.47, -3.45])
    np.testing.assert_allclose(td.numpy(), y - 2, rtol=1e-6)
    assert loss.item() == pytest.approx(np.mean((y - 2) ** 2), rel=1e-6)


def test_actor_loss_does_not_train_the_critic():
    from acder_lite.config import Config
    from acder_lite.algo.ddpg import DDPG

    torch.manual_seed(0)
    cfg = Config(hidden=16, layers=2).resolve()
    agent = DDPG(3, 2, cfg)
    b = batch()
    # the critic's step must equal a step on the critic loss alone
    ref = DDPG(3, 2, cfg)
    ref.load_state_dict(agent.state_dict())
    agent.update(b, (-50.0, 0.0))
    loss, _ = compute_loss_q(
        ref.critic, ref.actor_targ, ref.critic_targ, b, cfg.gamma, (-50.0, 0.0)
    )
    ref.q_opt.zero_grad()
    loss.backward()
    ref.q_opt.step()
    for p, q in zip(agent.critic.parameters(), ref.critic.parameters()):
        torch.testing.assert_close(p, q)


def random_batch(n: int) -> dict:
    """n rows of 10 input numbers and 4 action ones; 80% of the rewards are -1."""
    return dict(
        x=torch.randn(n, 10),
        x2=torch.randn(n, 10),
        u=torch.rand(n, 4) * 2 - 1,
        r=-(torch.rand(n) < 0.8).float(),
    )


def test_frozen_view_shares_the_weights_without_their_gradients():
    from acder_lite.algo.core import Critic, frozen_view

    torch.manual_seed(0)
    net = Critic(3, 2, hidden=8, layers=2)
    view = frozen_view(net)
    x, u = torch.randn(5, 3), torch.rand(5, 2)
    assert torch.equal(view(x, u), net(x, u))
    opt = torch.optim.Adam(net.parameters(), lr=0.1)
    net(x, u).sum().backward()
    opt.step()  # in place: the view follows
    assert torch.equal(view(x, u), net(x, u))
    other = Critic(3, 2, hidden=8, layers=2)
    net.load_state_dict(other.state_dict())  # in place too
    assert torch.equal(view(x, u), other(x, u))
    # a loss through the view: gradients for its input, none for any weight
    net.zero_grad(set_to_none=True)
    xg = x.clone().requires_grad_(True)
    view(xg, u).sum().backward()
    assert xg.grad is not None and xg.grad.abs().sum() > 0
    assert all(p.grad is None for p in net.parameters())
    assert all(not p.requires_grad for p in view.parameters())
    assert all(p.requires_grad for p in net.parameters())


@pytest.mark.parametrize("update_dtype", ["float32", "bfloat16"])
def test_split_update_is_the_one_thread_update(update_dtype):
    """The two losses at once (split_update='on') against one after the other: the
    same weights, bit for bit, after 5 steps (one intra-op thread each). bfloat16:
    the actor's thread enters autocast itself."""
    from acder_lite.config import Config
    from acder_lite.algo.ddpg import DDPG

    torch.set_num_threads(1)
    torch.manual_seed(0)
    b = random_batch(256)
    agents = {}
    for split in ("off", "on"):
        torch.manual_seed(1)
        cfg = Config(split_update=split, update_dtype=update_dtype, hidden=32)
        agents[split] = DDPG(10, 4, cfg.resolve())
    assert agents["off"].actor_thread is None and agents["on"].actor_thread is not None
    for _ in range(5):
        out = {k: a.update(b, (-50.0, 0.0)) for k, a in agents.items()}
        for k in ("critic_loss", "actor_loss", "td"):
            assert torch.equal(out["off"][k], out["on"][k]), k
    for net in ("actor", "critic"):
        for k, v in getattr(agents["off"], net).state_dict().items():
            assert torch.equal(v, getattr(agents["on"], net).state_dict()[k]), k


def test_bfloat16_update_follows_float32():
    """`update_dtype='bfloat16'`: the same step as fp32 up to bf16 rounding,
    on fp32 weights."""
    from acder_lite.config import Config
    from acder_lite.algo.ddpg import DDPG

    torch.manual_seed(0)
    b = random_batch(512)
    agents = {}
    for dt in ("float32", "bfloat16"):
        torch.manual_seed(1)
        agents[dt] = DDPG(10, 4, Config(update_dtype=dt).resolve())
    out = {dt: a.update(b, (-50.0, 0.0)) for dt, a in agents.items()}
    f, h = out["float32"], out["bfloat16"]
    for k in ("critic_loss", "actor_loss"):
        assert h[k].dtype == torch.float32
        assert h[k].item() == pytest.approx(f[k].item(), rel=2e-2, abs=2e-3)
    torch.testing.assert_close(h["td"], f["td"], rtol=0, atol=0.05)
    for net in ("critic", "actor"):
        pf = list(getattr(agents["float32"], net).parameters())
        ph = list(getattr(agents["bfloat16"], net).parameters())
        assert all(
            p.dtype == torch.float32 and p.grad.dtype == torch.float32 for p in ph
        )
        # the gradients of this step (left in .grad): close as a whole,
        # not bit-identical
        gf = torch.cat([p.grad.flatten() for p in pf])
        gh = torch.cat([p.grad.flatten() for p in ph])
        rel = float((gh - gf).norm() / gf.norm())
        assert 0 < rel < 0.05, (net, rel)


def test_polyak():
    from acder_lite.config import Config
    from acder_lite.algo.ddpg import DDPG

    cfg = Config(hidden=8, layers=1, polyak=0.95).resolve()
    agent = DDPG(3, 2, cfg)
    for p in agent.actor.parameters():
        p.data.fill_(1.0)
    for p in agent.actor_targ.parameters():
        p.data.fill_(0.0)
    for p in agent.critic.parameters():
        p.data.fill_(1.0)
    for p in agent.critic_targ.parameters():
        p.data.fill_(0.0)
    agent.update_targets()
    for targ in (agent.actor_targ, agent.critic_targ):  # both targets follow
        for p in targ.parameters():
            assert torch.allclose(p, torch.full_like(p, 0.05))
    agent.update_targets()  # 1 - 0.95^2
    for targ in (agent.actor_targ, agent.critic_targ):
        for p in targ.parameters():
            assert torch.allclose(p, torch.full_like(p, 0.0975))


def test_sicm_step_loss_is_eq8_on_a_hand_worked_batch():
    """L_F (Eq. 8) is the batch mean of 1/2 ||F(s, a) - s'||^2. With every weight and
    bias at zero F predicts 0, so the rows (1, 2) and (3, 0) cost 2.5 and 4.5: L_F =
    3.5. What `step` returns is from before its Adam step; the weights then move."""
    m = SICM(2, 1, hidden=4, lr=1e-2)
    for p in m.parameters():
        torch.nn.init.zeros_(p)
    s, a = torch.zeros(2, 2), torch.zeros(2, 1)
    s2 = torch.tensor([[1.0, 2.0], [3.0, 0.0]])
    err, _ = m.errors(s, a, s2)
    assert err.tolist() == [2.5, 4.5]
    pred, target, loss = m.step(s, a, s2)
    assert float(loss) == 3.5
    assert pred.abs().sum() == 0 and torch.equal(target, s2)
    assert m.net[-1].bias.abs().sum() > 0  # the output bias took the step


def test_icm_step_loss_is_the_weighted_sum_on_a_hand_worked_batch():
    """ICM's loss (1 - beta) L_I + beta L_F by hand, beta = 0.2. Every weight and bias
    at zero but the forward model's last bias at 1: phi = 0, the inverse model predicts
    a_hat = 0, the forward model predicts (1, 1, 1) against phi(s') = 0. L_I is the
    batch mean of the squared error summed over the action's dimensions: the actions
    (1, 2) and (3, 0) cost 5 and 9, L_I = 7 (a per-element mean, torch's mse_loss,
    would give 3.5); L_F is the batch mean of 1/2 ||phi_hat - phi||^2 = 1/2 * 3 = 1.5.
    Loss = 0.8 * 7 + 0.2 * 1.5 = 5.9, from before the Adam step."""
    m = ICM(2, 2, feat_dim=3, hidden=4, beta=0.2)
    for p in m.parameters():
        torch.nn.init.zeros_(p)
    with torch.no_grad():
        m.forward_model[-1].bias.fill_(1.0)
    s = s2 = torch.zeros(2, 2)
    a = torch.tensor([[1.0, 2.0], [3.0, 0.0]])
    with torch.no_grad():
        err, inv, fwd, pred, target = m.losses(s, a, s2)
    assert err.tolist() == [1.5, 1.5] and float(inv) == 7.0 and float(fwd) == 1.5
    assert torch.equal(pred, torch.ones(2, 3))
    assert torch.equal(target, torch.zeros(2, 3))
    pred, target, loss = m.step(s, a, s2)
    assert float(loss) == pytest.approx(0.8 * 7 + 0.2 * 1.5, rel=1e-6)  # 5.9
    assert float(loss) == pytest.approx(5.9, rel=1e-6)
    assert torch.equal(pred, torch.ones(2, 3))  # from before the step
    assert m.inverse[-1].bias.abs().sum() > 0  # the inverse model took the step


@pytest.mark.parametrize("cls", [SICM, ICM])
def test_curiosity_losses_decrease_on_a_fixed_batch(cls):
    from acder_lite.algo.rewards import intrinsic_reward

    torch.manual_seed(0)
    s, a = torch.randn(256, 6), torch.rand(256, 2) * 2 - 1
    s2 = s + 0.1 * torch.cat([a, a, a], -1)  # a simple dynamics to learn
    m = (
        cls(6, 2, hidden=64, lr=1e-3)
        if cls is SICM
        else cls(6, 2, feat_dim=16, hidden=64, lr=1e-3)
    )
    first = [float(m.step(s, a, s2)[2]) for _ in range(5)]
    for _ in range(300):
        pred, target, loss = m.step(s, a, s2)
    assert float(loss) < 0.3 * np.mean(first)
    r = intrinsic_reward(
        pred.numpy(), target.numpy(), 0.8
    )  # Eq. 4 of what step returns
    assert r.shape == (256,) and float(r.min()) >= 0 and float(r.max()) <= 0.8
    assert not pred.requires_grad and not target.requires_grad


def test_sicm_reward_is_eq4_before_the_update():
    from acder_lite.algo.rewards import intrinsic_reward

    torch.manual_seed(1)
    m = SICM(5, 2, hidden=16)
    s, a, s2 = torch.randn(8, 5), torch.randn(8, 2), torch.randn(8, 5)
    with torch.no_grad():
        want = intrinsic_reward(m(s, a).numpy(), s2.numpy(), 0.8)
    pred, target, _ = m.step(s, a, s2)
    torch.testing.assert_close(target, s2)  # S-ICM's target is s' itself
    np.testing.assert_allclose(
        intrinsic_reward(pred.numpy(), target.numpy(), 0.8), want, rtol=1e-5
    )
    with torch.no_grad():  # ... and the model did take a step
        assert not torch.allclose(m(s, a), pred)


def test_icm_reward_is_on_its_features_before_the_update():
    """ICM's (pred, target) are phi(s') as its forward model predicts it and
    phi(s') itself."""
    from acder_lite.algo.rewards import intrinsic_reward

    torch.manual_seed(2)
    m = ICM(5, 2, feat_dim=4, hidden=16)
    s, a, s2 = torch.randn(8, 5), torch.randn(8, 2), torch.randn(8, 5)
    with torch.no_grad():
        f, f2 = m.phi(s), m.phi(s2)
        want_pred = m.forward_model(torch.cat([f, a], -1))
    pred, target, _ = m.step(s, a, s2)
    assert pred.shape == target.shape == (8, 4)
    torch.testing.assert_close(target, f2)
    torch.testing.assert_close(pred, want_pred)
    r = intrinsic_reward(pred.numpy(), target.numpy(), 0.8)
    np.testing.assert_allclose(
        r, np.clip(0.5 * ((want_pred - f2) ** 2).sum(-1).numpy(), 0, 0.8), rtol=1e-5
    )


@pytest.mark.parametrize("cls", [SICM, ICM])
def test_curiosity_step_after_gives_the_stepped_models_prediction(cls):
    """Config.intrinsic_timing="after" (departure 8): the same Adam step, the same
    loss, and the (pred, target) of the networks once stepped."""
    s, a, s2 = torch.randn(8, 5), torch.randn(8, 2), torch.randn(8, 5)
    out = {}
    for after in (False, True):
        torch.manual_seed(3)
        m = SICM(5, 2, hidden=16) if cls is SICM else ICM(5, 2, feat_dim=4, hidden=16)
        out[after] = m.step(s, a, s2, after=after)
        with torch.no_grad():
            if cls is SICM:
                now = (m(s, a), s2)
            else:
                now = m.losses(s, a, s2)[3:]
    (p0, _, l0), (p1, t1, l1) = out[False], out[True]
    assert float(l0) == float(l1)  # the loss of the one step both took
    torch.testing.assert_close(p1, now[0])
    torch.testing.assert_close(t1, now[1])
    assert not torch.allclose(p0, p1)  # the step moved the prediction
    assert not p1.requires_grad and not t1.requires_grad


def test_icm_inverse_model_reads_phi_of_both_states():
    """ICM's inverse model predicts a_t from (phi(s_t), phi(s_{t+1})) (Pathak et al.
    2017), so its loss depends on s_{t+1}. Hand-set networks: phi(s) = relu(s) (the
    identity on s >= 0) and an inverse model a_hat = phi(s') - phi(s) (through
    relu(d) - relu(-d)). On transitions with s' = s + a its loss is 0; with a = 0 it
    is mean ||s' - s||^2 = ((0.5^2 + 1^2) + (2^2 + 0.5^2)) / 2 = 2.75. An inverse model
    fed phi(s) twice (or phi(s') twice) predicts 0 and gets 2.75 on the first batch."""
    m = ICM(2, 2, feat_dim=2, hidden=4)
    with torch.no_grad():
        for p in m.parameters():
            p.zero_()
        m.phi[0].weight[:2] = torch.eye(2)
        m.phi[2].weight[:, :2] = torch.eye(2)
        # input [phi(s), phi(s')]; hidden relu(+-(phi(s')_k - phi(s)_k))
        m.inverse[0].weight.copy_(
            torch.tensor([[-1.0, 0, 1, 0], [1, 0, -1, 0], [0, -1, 0, 1], [0, 1, 0, -1]])
        )
        m.inverse[2].weight.copy_(torch.tensor([[1.0, -1, 0, 0], [0, 0, 1, -1]]))
    s = torch.tensor([[1.0, 2.0], [3.0, 1.0]])
    a = torch.tensor([[0.5, -1.0], [-2.0, 0.5]])
    with torch.no_grad():
        inv = m.losses(s, a, s + a)[1]
        assert inv.item() == pytest.approx(0.0, abs=1e-12)
        inv = m.losses(s, torch.zeros(2, 2), s + a)[1]
        assert inv.item() == pytest.approx(2.75, rel=1e-6)


def test_update_takes_eq2s_target_from_the_target_actor():
    """Eq. 2 inside `DDPG.update`: y = r + gamma Q'(s', pi'(s')) with pi' the target
    actor, not the online one. Hand-set networks (hidden 4, one layer): Q = 0,
    Q'(s, u) = relu(u_1 + u_2), pi' = tanh(0) = 0, pi = tanh(1) = 0.7616. With pi',
    y = r, so td = r = [-1, 0, -1, -1] and the critic loss is 3/4. With the online
    actor y = r + 0.98 * 1.5232 clips to 0 on every row (clip [-50, 0]) and td = 0. The
    networks are set after construction, where actor and target are still equal."""
    from acder_lite.config import Config
    from acder_lite.algo.ddpg import DDPG

    agent = DDPG(3, 2, Config(hidden=4, layers=1, gamma=0.98).resolve())
    with torch.no_grad():
        for net in (agent.actor, agent.actor_targ, agent.critic, agent.critic_targ):
            for p in net.parameters():
                p.zero_()
        agent.actor.net[-2].bias.fill_(1.0)  # pi = tanh(1) in both dims
        agent.critic_targ.net[0].weight[0, 3:] = 1.0  # hidden unit 0: u_1 + u_2
        agent.critic_targ.net[-1].weight[0, 0] = 1.0
    b = batch()
    out = agent.update(b, (-50.0, 0.0))
    np.testing.assert_allclose(out["td"].numpy(), [-1.0, 0.0, -1.0, -1.0], atol=1e-6)
    assert out["critic_loss"].item() == pytest.approx(0.75, rel=1e-6)


def test_icms_forward_loss_does_not_move_the_features():
    """Departure 9: only the inverse loss trains the encoder phi. With beta = 1 the
    loss is the forward loss alone: a step moves the forward model and leaves phi as
    it was (Adam's step of a zero gradient is zero)."""
    torch.manual_seed(5)
    m = ICM(5, 2, feat_dim=4, hidden=16, beta=1.0)
    s, a, s2 = torch.randn(8, 5), torch.randn(8, 2), torch.randn(8, 5)
    phi = [p.detach().clone() for p in m.phi.parameters()]
    fwd = [p.detach().clone() for p in m.forward_model.parameters()]
    m.step(s, a, s2)
    assert all(torch.equal(p, q) for p, q in zip(m.phi.parameters(), phi))
    assert not all(torch.equal(p, q) for p, q in zip(m.forward_model.parameters(), fwd))
