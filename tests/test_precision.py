"""--update-dtype auto: bfloat16 only where the update measured clearly faster in it
(timed on the machine it runs on; float32 without timing where the CPU has no native
bfloat16); the choice and why recorded, and kept by a resumed run."""

import json

import pytest

from acder_lite.cli import main as cli
from acder_lite import precision
from acder_lite.config import Config


@pytest.fixture(autouse=True)
def fresh_measurements(monkeypatch):
    """Each test starts with no timing cached (`precision._MEASURED`)."""
    monkeypatch.setattr(precision, "_MEASURED", {})


def stub_timer(monkeypatch, f32: float, bf16: float) -> list:
    """`time_update` replaced by one that says float32 took `f32` s and bfloat16 `bf16`;
    returns the list of the shapes it was asked to time."""
    asked = []

    def timer(rows, hidden, layers, threads):
        asked.append((rows, hidden, layers, threads))
        return f32, bf16

    monkeypatch.setattr(precision, "time_update", timer)
    return asked


@pytest.mark.parametrize(
    "f32, bf16, want",
    [
        (10e-3, 5e-3, "bfloat16"),  # 2x
        (10e-3, 8e-3, "bfloat16"),  # 1.25x
        (10e-3, 10e-3 / 1.1, "float32"),  # faster, but not clearly: noise could flip it
        (10e-3, 15e-3, "float32"),  # slower (a Xeon with AVX512-BF16, no AMX: 0.62x)
    ],
)
def test_auto_takes_bfloat16_only_where_it_measured_clearly_faster(
    monkeypatch, f32, bf16, want
):
    monkeypatch.setattr(precision, "native_bf16", lambda: (True, "the CPU has probe"))
    asked = stub_timer(monkeypatch, f32, bf16)
    cfg = Config(
        env="FetchPush-v4", batch_size=64, workers=3, hidden=48, layers=2, threads=4
    ).resolve()
    # the run's own update: batch_size x workers rows, its networks, its torch threads
    # (threads 4 split between the two losses: 2 each)
    assert asked == [(192, 48, 2, 2)]
    assert cfg.update_dtype == want
    why = cfg.update_dtype_why
    assert why.startswith("auto: the CPU has probe; ") and why.endswith(f": {want}")
    assert f"float32 {f32 * 1e3:.2f} ms, bfloat16 {bf16 * 1e3:.2f} ms" in why
    assert "\n" not in why
    assert precision.BF16_MIN_SPEEDUP == 1.2


def test_auto_without_native_bf16_takes_float32_without_timing(monkeypatch):
    monkeypatch.setattr(precision, "native_bf16", lambda: (False, "no bf16 here"))
    asked = stub_timer(monkeypatch, 10.0, 1.0)  # would say bfloat16, if asked
    cfg = Config(env="FetchPush-v4").resolve()
    assert asked == []
    assert (cfg.update_dtype, cfg.update_dtype_why) == (
        "float32",
        "auto: no bf16 here: float32, not timed",
    )


def test_explicit_dtypes_and_cuda_are_not_timed(monkeypatch):
    monkeypatch.setattr(precision, "native_bf16", lambda: (True, "probe"))
    asked = stub_timer(monkeypatch, 10.0, 1.0)
    for dtype in ("float32", "bfloat16"):
        cfg = Config(env="FetchPush-v4", update_dtype=dtype).resolve()
        assert (cfg.update_dtype, cfg.update_dtype_why) == (dtype, "asked for")
    assert precision.choose_update_dtype("auto", "cuda")[0] == "float32"
    assert asked == []


def test_a_shape_is_timed_once_a_process(monkeypatch):
    """Every resolve of one run (train's check, the trainer's) and of a sweep's task
    reads the same timing, so they make the same choice."""
    monkeypatch.setattr(precision, "native_bf16", lambda: (True, "probe"))
    asked = stub_timer(monkeypatch, 2.0, 1.0)
    a = Config(env="FetchPush-v4", method="her").resolve()
    b = Config(env="FetchPush-v4", method="acder").resolve()
    assert len(asked) == 1
    assert (a.update_dtype, a.update_dtype_why) == (b.update_dtype, b.update_dtype_why)
    Config(env="FetchPush-v4", hidden=64).resolve()  # another shape: timed
    assert len(asked) == 2


def test_a_resumed_config_keeps_its_precision(monkeypatch):
    """A checkpoint's config has update_dtype resolved, and its why: resolve keeps
    both and times nothing, whatever this machine would pick now."""
    monkeypatch.setattr(precision, "native_bf16", lambda: (True, "probe"))
    stub_timer(monkeypatch, 2.0, 1.0)
    started = Config(env="FetchPush-v4").resolve()
    assert started.update_dtype == "bfloat16"
    monkeypatch.setattr(precision, "_MEASURED", {})
    asked = stub_timer(monkeypatch, 1.0, 2.0)  # this machine: bfloat16 slower
    again = Config.from_dict(started.to_dict()).resolve()
    assert asked == []
    assert (again.update_dtype, again.update_dtype_why) == (
        "bfloat16",
        started.update_dtype_why,
    )
    assert Config(env="FetchPush-v4").resolve().update_dtype == "float32"  # a new run


def test_time_update_measures_both_precisions_and_leaves_the_run_alone():
    """Two positive timings of a small update; the torch threads as they were and the
    global generator, which seeds a run, not drawn from."""
    import torch

    threads = torch.get_num_threads()
    torch.manual_seed(7)
    want = torch.rand(3)
    torch.manual_seed(7)
    f32, bf16 = precision.time_update(16, 8, 2, 1, seconds=0.05)
    assert f32 > 0 and bf16 > 0
    assert torch.equal(torch.rand(3), want)
    assert torch.get_num_threads() == threads


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
    stub_timer(monkeypatch, 10.0, 1.0)  # not asked: no native bfloat16
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
        "auto: no AVX512-BF16: float32, not timed",
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


@pytest.mark.parametrize(
    "native, f32, want, tail",
    [
        (True, 2.0, "bfloat16", "2.00x, at least 1.2x: bfloat16)"),
        (True, 1.0, "float32", "1.00x, under 1.2x: float32)"),
        (False, 2.0, "float32", "(auto: probe: float32, not timed)"),
    ],
)
def test_the_chapters_first_cell_says_which_precision_trains(
    monkeypatch, capsys, native, f32, want, tail
):
    # the chapters train with update_dtype="auto"; `budgets` prints what it chose here
    from acder_lite.book.utils import budgets

    monkeypatch.setattr(precision, "native_bf16", lambda: (native, "probe"))
    stub_timer(monkeypatch, f32, 1.0)
    assert budgets(True, cycles=(40, 8)) == {"cycles": 8}
    lines = capsys.readouterr().out.splitlines()
    assert len(lines) == 2 and lines[0] == "ACDER_FAST=1: cycles=8"
    assert lines[1].startswith(f"network updates in {want} on this CPU (auto: probe")
    assert lines[1].endswith(tail)


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
