"""The opt-in compiled update (`Config.compile_update`): the eager update within float32
tolerance, and never reached by the default path."""

import pytest
import torch

from acder_lite.config import Config, ConfigError
from acder_lite.algo.ddpg import DDPG, compute_loss_pi, compute_loss_q

# one worker (`make test`: --dist loadgroup): the first test's graphs serve the rest
pytestmark = pytest.mark.xdist_group("compile")


def random_batch(n: int) -> dict:
    torch.manual_seed(0)
    return dict(
        x=torch.randn(n, 10),
        x2=torch.randn(n, 10),
        u=torch.rand(n, 4) * 2 - 1,
        r=-(torch.rand(n) < 0.8).float(),
    )


def agent(**kw) -> DDPG:
    """float32 named: `auto` is bfloat16 where the update measured faster in it, and
    there the compiled and eager updates round differently by more than float32's
    tolerance."""
    torch.manual_seed(1)
    kw.setdefault("update_dtype", "float32")
    return DDPG(10, 4, Config(hidden=32, threads=1, **kw).resolve())


def params(a: DDPG) -> dict:
    return {
        f"{net}.{k}": v
        for net in ("actor", "critic")
        for k, v in getattr(a, net).state_dict().items()
    }


def test_the_default_update_never_calls_torch_compile(monkeypatch):
    def refuse(*args, **kwargs):
        raise AssertionError("torch.compile called by the default update")

    monkeypatch.setattr(torch, "compile", refuse)
    assert Config().compile_update is False
    for split in ("off", "on"):
        a = agent(split_update=split)
        assert a.loss_q is compute_loss_q and a.loss_pi is compute_loss_pi
        for _ in range(2):
            a.update(random_batch(64), (-50.0, 0.0))


def test_compiled_update_follows_eager():
    """3 steps on a fixed batch, float32: every weight within rtol 1e-5 (atol 1e-7,
    for weights near 0) of the eager update's, the losses and |TD| too; not the same
    computation (the compiled losses are other callables)."""
    torch.set_num_threads(1)
    b = random_batch(256)
    eager, comp = agent(), agent(compile_update=True)
    assert comp.loss_q is not compute_loss_q and comp.loss_pi is not compute_loss_pi
    for _ in range(3):
        oe = eager.update(b, (-50.0, 0.0))
        oc = comp.update(b, (-50.0, 0.0))
        for k in ("critic_loss", "actor_loss", "td"):
            assert torch.allclose(oc[k], oe[k], rtol=1e-5, atol=1e-6), k
    pe, pc = params(eager), params(comp)
    for k, v in pe.items():
        assert torch.allclose(pc[k], v, rtol=1e-5, atol=1e-7), k
    # the optimisers stepped the compiled agent's own weights (not a copy)
    assert not torch.equal(
        pc["critic.net.0.weight"], params(agent())["critic.net.0.weight"]
    )


def test_compiled_split_update_is_the_one_thread_compiled_update():
    """split_update='on' with compiled losses (the first update compiles both in one
    thread, then they run at once): bit for bit the compiled one-thread update."""
    torch.set_num_threads(1)
    b = random_batch(256)
    off, on = (agent(compile_update=True, split_update=s) for s in ("off", "on"))
    assert on.actor_thread is not None and not on.compiled_once
    for _ in range(3):
        o_off, o_on = off.update(b, (-50.0, 0.0)), on.update(b, (-50.0, 0.0))
        for k in ("critic_loss", "actor_loss", "td"):
            assert torch.equal(o_off[k], o_on[k]), k
    assert on.compiled_once
    p_off, p_on = params(off), params(on)
    for k, v in p_off.items():
        assert torch.equal(p_on[k], v), k


def test_compile_update_option():
    from acder_lite.cli.main import build_parser
    from acder_lite.cli import sweep as S
    from acder_lite.runs.plan import Cell, run_dir

    parse = build_parser().parse_args
    assert parse(["train", "--compile-update", "--out", "x"]).compile_update is True
    # absent: None, i.e. not given, so the Config default (or a checkpoint's) holds
    assert parse(["train", "--out", "x"]).compile_update is None
    assert parse(["bench", "--compile-update"]).compile_update is True
    assert parse(["bench"]).compile_update is False
    with pytest.raises(ConfigError, match="compile_update='yes' is not allowed"):
        Config(compile_update="yes").validate()
    # a plan's `compile_update = true` reaches train as the flag
    cell = Cell(
        env="FetchPush-v4",
        method="her",
        seed=0,
        out=run_dir("r", "FetchPush-v4", "her", 0),
        action="run",
        options={"compile_update": True},
    )
    args = build_parser().parse_args(["sweep", "--plan", "p.toml"])
    argv = S.train_argv(cell, args, resume=False)
    assert "--compile-update" in argv and "True" not in argv
    cell.options = {"compile_update": False}
    assert "--compile-update" not in S.train_argv(cell, args, resume=False)


def test_compile_loss_uses_the_default_partitioner(monkeypatch):
    """compile_loss asks inductor for AOTAutograd's default partitioner (not min-cut,
    whose bool ReLU masks made the compiled update 1.35x slower), static shapes and
    one graph; the loss function itself is what is compiled."""
    from acder_lite.algo.compiled import DefaultPartition, compile_loss

    seen = {}

    def record(fn, **kw):
        seen.update(kw, fn=fn)
        return fn

    monkeypatch.setattr(torch, "compile", record)
    assert compile_loss(compute_loss_q) is compute_loss_q
    assert seen["fn"] is compute_loss_q
    assert (seen["dynamic"], seen["fullgraph"]) == (False, True)
    assert isinstance(seen["options"]["custom_partitioner_fn"], DefaultPartition)
