"""--device auto|cpu|cuda:
resolution, the error without CUDA, and the device as a parameter.

This machine has no GPU, so what can be checked here is the plumbing: the choice and why
are recorded, `cpu` is the default's very computation, every tensor an update touches is
on the trainer's device (a dispatch mode sees each aten call), and a checkpoint resumes
onto it. The limit of that: on a CPU-only machine every tensor is on the CPU anyway, so
a missing `.to(device)` cannot show up here; the device checks bite only where torch
sees a GPU (`--device cuda`), and `bench --device cuda` there is the end-to-end check.
"""

import json

import pytest
import torch
from torch.utils._python_dispatch import TorchDispatchMode

from acder_lite.cli import main as cli
from acder_lite import precision
from acder_lite.config import Config, ConfigError
from acder_lite.io import load_torch
from acder_lite.train.trainer import Trainer

from conftest import networks, rows_of, tiny_config

TINY = (
    "--env FetchPush-v4 --method acder --seed 0 --epochs 2 --cycles 2 "
    "--workers 2 --updates-per-cycle 2 --test-episodes 1 --batch-size 16 "
    "--hidden 16 --sicm-hidden 16 --buffer-size 1000 --threads 1 --quiet"
).split()


def test_auto_follows_cuda(monkeypatch):
    monkeypatch.setattr(torch.cuda, "is_available", lambda: False)
    cfg = Config(env="FetchPush-v4").resolve()
    assert cfg.device == "cpu" and cfg.device_why.startswith("auto: no CUDA")
    monkeypatch.setattr(torch.cuda, "is_available", lambda: True)
    monkeypatch.setattr(torch.cuda, "get_device_name", lambda i=0: "Fake GPU")
    cfg = Config(env="FetchPush-v4").resolve()
    assert (cfg.device, cfg.device_why) == (
        "cuda",
        "auto: CUDA is available (Fake GPU)",
    )
    # on CUDA, auto keeps float32: the CPU's bfloat16 probe says nothing about the GPU
    assert cfg.update_dtype == "float32" and "cuda" in cfg.update_dtype_why
    assert Config(env="FetchPush-v4", device="cpu").resolve().device == "cpu"


def test_a_resolved_choice_is_kept():
    cfg = Config(env="FetchPush-v4", device="cpu").resolve()
    again = Config.from_dict(cfg.to_dict()).resolve()  # a resumed run keeps it, and why
    assert (again.device, again.device_why) == ("cpu", "asked for")
    with pytest.raises(
        ConfigError, match="device='gpu' is not allowed: 'auto' or 'cpu' or 'cuda'"
    ):
        Config(env="FetchPush-v4", device="gpu").resolve()


def test_cuda_without_cuda_is_one_line_and_exit_2(monkeypatch, tmp_path, capsys):
    monkeypatch.setattr(torch.cuda, "is_available", lambda: False)
    with pytest.raises(ConfigError, match="device='cuda' is not allowed"):
        Config(env="FetchPush-v4", device="cuda").resolve()
    assert (
        cli.main(["train", *TINY, "--device", "cuda", "--out", str(tmp_path / "a")])
        == 2
    )
    err = capsys.readouterr().err
    assert (
        err.count("\n") == 1
        and "device='cuda'" in err
        and "allowed: 'auto' or 'cpu'" in err
    )
    assert not (tmp_path / "a").exists()


def test_cpu_is_the_defaults_computation(monkeypatch):
    """Without CUDA, `auto` resolves to `cpu` in `Config.resolve`, before anything is
    built: the resolved config, which is all a Trainer reads, is `device="cpu"`'s
    field for field but for the recorded reason. (Two trainings, auto against cpu,
    would train one config twice on a CPU-only machine: they show nothing more.)"""
    monkeypatch.setattr(torch.cuda, "is_available", lambda: False)
    auto = Config(env="FetchPush-v4").resolve()
    cpu = Config(env="FetchPush-v4", device="cpu").resolve()
    assert auto.device == cpu.device == "cpu"
    assert auto.device_why.startswith("auto: no CUDA")
    assert cpu.device_why == "asked for"
    a, b = auto.to_dict(), cpu.to_dict()
    # update_dtype's auto, resolved on the device, included
    assert a.pop("device_why") != b.pop("device_why") and a == b


class Devices(TorchDispatchMode):
    """Every device an aten call's tensor arguments and results live on."""

    def __init__(self):
        super().__init__()
        self.seen = set()

    def __torch_dispatch__(self, func, types, args=(), kwargs=None):
        out = func(*args, **(kwargs or {}))
        for x in torch.utils._pytree.tree_leaves((args, kwargs, out)):
            if isinstance(x, torch.Tensor):
                self.seen.add(x.device)
        return out


@pytest.mark.parametrize("method", ["acder", "her-per", "her-icm"])
def test_the_update_runs_on_the_trainers_device(method):
    tr = Trainer(tiny_config(method=method, env="FetchPush-v4", device="cpu"))
    tr.train_cycle()  # a filled buffer, optimiser states
    want = tr.device
    assert (
        want == torch.device("cpu")
        and tr.policy.device == want
        and tr.agent.device == want
    )
    nets = networks(tr)
    opts = [tr.agent.pi_opt, tr.agent.q_opt] + (
        [tr.curiosity.opt] if tr.curiosity else []
    )
    for net in filter(None, nets):
        assert {p.device for p in net.parameters()} == {want}
    for opt in opts:
        states = [
            v for s in opt.state.values() for v in s.values() if torch.is_tensor(v)
        ]
        assert states and {v.device for v in states if v.dim()} == {want}
    batch = tr.sample_batch()
    tb = tr.batch_tensors(batch)
    assert {t.device for t in tb.values()} == {want}
    with Devices() as mode:
        tr.update_step()
    assert mode.seen == {want}


def test_checkpoint_resumes_onto_the_runs_device(tmp_path, capsys):
    full, part = str(tmp_path / "full"), str(tmp_path / "part")
    assert cli.main(["train", *TINY, "--device", "cpu", "--out", full]) == 0
    assert (
        cli.main(
            [
                "train",
                *TINY[:-1],
                "--epochs",
                "1",
                "--device",
                "cpu",
                "--out",
                part,
                "--quiet",
            ]
        )
        == 0
    )
    # resumed with an explicit device: resolved again, the checkpoint loaded onto it
    assert (
        cli.main(
            ["train", "--resume", part, "--epochs", "2", "--device", "cpu", "--quiet"]
        )
        == 0
    )
    assert rows_of(f"{part}/progress.csv") == rows_of(f"{full}/progress.csv")
    a, b = (
        load_torch(f"{full}/policy.pt")["policy"],
        load_torch(f"{part}/policy.pt")["policy"],
    )
    assert all(torch.equal(a["actor"][k], b["actor"][k]) for k in a["actor"])
    resumed = json.loads((tmp_path / "part" / "config.json").read_text())
    assert resumed["config"]["device"] == "cpu" and resumed["resumes"]


def test_policy_rebuilds_on_a_device():
    tr = Trainer(tiny_config(env="FetchPush-v4", device="cpu"))
    from acder_lite.train.rollout import Policy

    pol = Policy.from_state_dict(tr.policy_state(), device="cpu")
    assert next(pol.actor.parameters()).device == torch.device("cpu")
    assert precision.choose_device("cpu") == ("cpu", "asked for")
