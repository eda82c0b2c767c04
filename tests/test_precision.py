"""--update-dtype auto: bfloat16 only with native bfloat16 matmul;
the choice and why recorded."""

import json

import pytest

from acder_lite.cli import main as cli
from acder_lite import precision
from acder_lite.config import Config


@pytest.mark.parametrize("native, want", [(True, "bfloat16"), (False, "float32")])
def test_auto_follows_the_cpu(monkeypatch, native, want):
    monkeypatch.setattr(precision, "native_bf16", lambda: (native, "probe"))
    cfg = Config(env="FetchPush-v4").resolve()
    assert cfg.update_dtype == want and cfg.update_dtype_why == "auto: probe"
    assert (
        Config(env="FetchPush-v4", update_dtype="float32").resolve().update_dtype
        == "float32"
    )


def test_an_explicit_choice_is_kept_and_recorded():
    cfg = Config(env="FetchPush-v4", update_dtype="bfloat16").resolve()
    assert (cfg.update_dtype, cfg.update_dtype_why) == ("bfloat16", "asked for")
    # a resumed run keeps the resolved choice
    again = Config.from_dict(cfg.to_dict()).resolve()
    assert (again.update_dtype, again.update_dtype_why) == ("bfloat16", "asked for")


def test_warning_only_without_native_bf16(monkeypatch):
    monkeypatch.setattr(precision, "native_bf16", lambda: (False, "no AVX512-BF16"))
    monkeypatch.setattr(precision, "bf16_cost", lambda: 17.0)
    msg = precision.warning_if_slow("bfloat16")
    assert msg.startswith("warning:") and "17.0x slower" in msg and "\n" not in msg
    assert precision.warning_if_slow("float32") is None
    monkeypatch.setattr(precision, "native_bf16", lambda: (True, "AMX"))
    assert precision.warning_if_slow("bfloat16") is None


def test_bf16_cost_is_a_measured_ratio(monkeypatch):
    """The ratio of the fastest bfloat16 matmul to the fastest float32 one: with a
    clock that times the float32 ones at 5, 2, 3 and the bfloat16 ones at 9, 7, 6, it
    is 6 / 2 = 3."""
    cost = precision.bf16_cost(n=64, d=32, reps=3)
    assert cost > 0 and cost == cost  # measured for real: a positive number, not NaN
    ticks, now = [], 0.0
    for f32, bf16 in ((5.0, 9.0), (2.0, 7.0), (3.0, 6.0)):  # start, end, start, end
        ticks += [now, now + f32, now + f32, now + f32 + bf16]
        now += f32 + bf16
    clock = iter(ticks)
    monkeypatch.setattr(precision.time, "perf_counter", lambda: next(clock))
    assert precision.bf16_cost(n=8, d=4, reps=3) == 3.0


def test_train_records_the_choice_and_warns(tmp_path, monkeypatch, capsys):
    monkeypatch.setattr(precision, "native_bf16", lambda: (False, "no AVX512-BF16"))
    monkeypatch.setattr(precision, "bf16_cost", lambda: 17.0)
    tiny = (
        "--env FetchReach-v4 --method her --seed 0 --epochs 1 --cycles 1 --workers 1 "
        "--updates-per-cycle 1 --test-episodes 1 --batch-size 8 --hidden 8 "
        "--buffer-size 1000 --threads 1 --quiet"
    ).split()
    assert cli.main(["train", *tiny, "--out", str(tmp_path / "a")]) == 0
    cfg = json.loads((tmp_path / "a" / "config.json").read_text())["config"]
    assert (cfg["update_dtype"], cfg["update_dtype_why"]) == (
        "float32",
        "auto: no AVX512-BF16",
    )
    assert "warning" not in capsys.readouterr().err
    assert (
        cli.main(
            ["train", *tiny, "--update-dtype", "bfloat16", "--out", str(tmp_path / "b")]
        )
        == 0
    )
    err = [
        line
        for line in capsys.readouterr().err.splitlines()
        if line.startswith("warning")
    ]
    assert len(err) == 1 and "17.0x slower" in err[0]


@pytest.mark.parametrize("native, want", [(True, "bfloat16"), (False, "float32")])
def test_the_chapters_first_cell_says_which_precision_trains(
    monkeypatch, capsys, native, want
):
    # the chapters train with update_dtype="auto"; `budgets` prints what it chose here
    from acder_lite.book.utils import budgets

    monkeypatch.setattr(precision, "native_bf16", lambda: (native, "probe"))
    assert budgets(True, cycles=(40, 8)) == {"cycles": 8}
    lines = capsys.readouterr().out.splitlines()
    assert lines == [
        "ACDER_FAST=1: cycles=8",
        f"network updates in {want} on this CPU (auto: probe)",
    ]


def test_native_bf16_reads_cpuinfo_only_where_torch_finds_nothing(monkeypatch):
    """torch's probes first; where they find nothing (or this torch lacks them), the
    flags of /proc/cpuinfo decide; where a probe finds AMX, cpuinfo is not read."""
    import io

    import torch

    for probe in ("_is_avx512_bf16_supported", "_is_amx_tile_supported"):
        monkeypatch.setattr(torch.cpu, probe, lambda: False, raising=False)

    def cpuinfo(flags):
        monkeypatch.setattr(
            precision, "open", lambda path: io.StringIO(flags), raising=False
        )

    cpuinfo("flags\t\t: fpu sse2 avx512f avx512_bf16\n")
    assert precision.native_bf16() == (True, "the CPU has AVX512-BF16")
    cpuinfo("flags\t\t: fpu sse2 avx2\n")
    assert precision.native_bf16()[0] is False
    monkeypatch.setattr(torch.cpu, "_is_amx_tile_supported", lambda: True)
    assert precision.native_bf16() == (True, "the CPU has AMX")
