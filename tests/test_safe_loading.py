"""Opening a policy or checkpoint never runs code from the file (issue 20).

Every torch file the project reads goes through `acder_lite.io.load_torch`: torch.load
with weights_only=True and the few numpy globals of `io.SAFE_GLOBALS`, then a check of
our layout. A file that is not ours gets one line naming it, exit code 2, no traceback,
and nothing from it runs.
"""

import glob
import os
import pickle
import re
import time

import numpy as np
import pytest
import torch

from acder_lite import io as aio
from acder_lite.io import CheckpointError, load_torch
from acder_lite.train.rollout import Policy
from acder_lite.train.trainer import Trainer
from conftest import ROOT, rows_of, tiny_config
from conftest import listening as _listening

COMMITTED = sorted(
    glob.glob(
        os.path.join(ROOT, "experiments", "protocol-v1", "**", "policy.pt"),
        recursive=True,
    )
)
REACH = os.path.join(
    ROOT, "experiments", "protocol-v1", "FetchReach-v4", "her", "seed0", "policy.pt"
)


def one_line(p, *needles) -> str:
    assert p.returncode == 2, (p.returncode, p.stdout, p.stderr)
    assert "Traceback" not in p.stderr, p.stderr
    lines = [ln for ln in p.stderr.splitlines() if ln.strip()]
    assert len(lines) == 1, p.stderr
    for n in needles:
        assert n in lines[0], lines[0]
    return lines[0]


# ----- files that would run something when unpickled


class _System:
    """Unpickling calls os.system('touch MARKER')."""

    def __init__(self, marker):
        self.marker = str(marker)

    def __reduce__(self):
        return os.system, (f"touch '{self.marker}'",)


class _Exec:
    """Unpickling calls exec(open(MARKER, 'w'))."""

    def __init__(self, marker):
        self.marker = str(marker)

    def __reduce__(self):
        return exec, (f"open({self.marker!r}, 'w').close()",)


def _crafted(tmp_path, kind: str, marker) -> str:
    """A file whose unpickling (by pickle, or torch.load(weights_only=False))
    creates `marker`."""
    path = tmp_path / f"{kind}.pt"
    if (
        kind == "torch-system"
    ):  # torch.save of a policy.pt-like dict with the payload inside
        torch.save({"policy": _System(marker)}, path)
    elif kind == "torch-exec":
        torch.save(_Exec(marker), path)
    elif kind == "pickle-system":  # a plain pickle.dump file
        with open(path, "wb") as f:
            pickle.dump(_System(marker), f)
    else:
        raise ValueError(kind)
    return str(path)


CRAFTED = ["torch-system", "torch-exec", "pickle-system"]


def test_the_payloads_are_live(tmp_path):
    """Guard for the tests below: unpickled the unsafe way,
    each crafted file does create its marker."""
    for kind in CRAFTED:
        marker = tmp_path / f"live-{kind}"
        path = _crafted(tmp_path, kind, marker)
        if kind.startswith("pickle"):
            with open(path, "rb") as f:
                pickle.load(f)
        else:
            torch.load(path, weights_only=False)
        assert marker.exists(), kind


@pytest.mark.parametrize("kind", CRAFTED)
def test_python_api_refuses_a_crafted_pickle(tmp_path, kind):
    marker = tmp_path / "marker"
    path = _crafted(tmp_path, kind, marker)
    before = set(map(repr, torch.serialization.get_safe_globals()))
    with pytest.raises(CheckpointError) as e:
        load_torch(path)
    msg = str(e.value)
    assert "\n" not in msg and path in msg and "allowed:" in msg
    if kind == "torch-system":
        assert re.search(r"(posix|os|nt)\.system", msg), msg
    if kind == "torch-exec":
        assert "exec" in msg, msg
    assert not marker.exists()
    assert (
        set(map(repr, torch.serialization.get_safe_globals())) == before
    )  # SAFE_GLOBALS only inside load_torch


@pytest.mark.parametrize("kind", CRAFTED)
def test_eval_refuses_a_crafted_pickle(tmp_path, cli, kind):
    marker = tmp_path / "marker"
    path = _crafted(tmp_path, kind, marker)
    line = one_line(cli("eval", "--checkpoint", path, "--episodes", "1"), path)
    assert "eval: env=" not in line
    assert not marker.exists()


@pytest.mark.parametrize("kind", ["torch-system", "pickle-system"])
def test_diagnose_refuses_a_crafted_pickle(tmp_path, cli, kind):
    """`diagnose RUN` reads RUN/checkpoint.pt;
    `diagnose RUN --episodes N` reads RUN/policy.pt."""
    marker = tmp_path / "marker"
    run = tmp_path / "run"
    run.mkdir()
    os.replace(_crafted(tmp_path, kind, marker), run / "checkpoint.pt")
    one_line(cli("diagnose", str(run)), str(run / "checkpoint.pt"))
    assert not marker.exists()
    os.replace(run / "checkpoint.pt", run / "policy.pt")
    one_line(cli("diagnose", str(run), "--episodes", "1"), str(run / "policy.pt"))
    assert not marker.exists()


def test_a_torch_zip_holding_a_protocol_4_pickle_is_refused_in_one_line(tmp_path):
    """A crafted zip whose data.pkl torch's safe unpickler cannot parse (and whose
    warning must not become a second line)."""
    marker = tmp_path / "marker"
    src = tmp_path / "src.pt"
    torch.save({"policy": 1}, src)
    dst = tmp_path / "zip4.pt"
    _rewrite_pickle(src, dst, lambda b: pickle.dumps(_System(marker), protocol=4))
    with pytest.raises(CheckpointError) as e:
        load_torch(str(dst))
    assert "\n" not in str(e.value) and str(dst) in str(e.value)
    assert not marker.exists()


def _rewrite_pickle(src, dst, edit) -> None:
    """Copy the torch zip `src` to `dst` with its data.pkl replaced by
    edit(data.pkl)."""
    import zipfile

    with (
        zipfile.ZipFile(src) as zin,
        zipfile.ZipFile(dst, "w", zipfile.ZIP_STORED) as zout,
    ):
        for item in zin.infolist():
            data = zin.read(item.filename)
            if item.filename.endswith("data.pkl"):
                data = edit(data)
            zout.writestr(item, data)


def test_a_policy_written_by_numpy_1_loads(tmp_path):
    """numpy 1.x wrote its array reconstructor as numpy.core.multiarray._reconstruct
    (numpy 2: numpy._core); SAFE_GLOBALS allows that name for the same function."""
    src = tmp_path / "v2.pt"
    torch.save(dict(policy=_policy()), src)
    old = tmp_path / "v1.pt"
    _rewrite_pickle(
        src,
        old,
        lambda b: b.replace(b"numpy._core.multiarray\n", b"numpy.core.multiarray\n"),
    )
    assert (
        "numpy.core.multiarray._reconstruct"
        in torch.serialization.get_unsafe_globals_in_checkpoint(str(old))
    )
    a, b = load_torch(str(src))["policy"], load_torch(str(old))["policy"]
    assert (
        np.array_equal(a["o_norm"]["sum"], b["o_norm"]["sum"])
        and a["o_norm"]["sum"].dtype == np.float64
    )


# ----- files that are not ours (but run nothing)


def _policy(path=REACH) -> dict:
    return load_torch(path)["policy"]


def _wrong_actor(pol):
    pol["actor"]["net.0.weight"] = torch.zeros(
        pol["shape"]["hidden"], pol["shape"]["in_dim"] + 3
    )
    return pol, "net.0.weight"


def _missing_layer(pol):
    del pol["actor"]["net.6.bias"]
    return pol, "net.6.bias"


def _wrong_record(pol):
    pol["shape"]["hidden"] = 64  # the tensors are 256 wide
    return pol, "shape"


def _wrong_norm(pol):
    pol["o_norm"]["sum"] = np.zeros(pol["norm"]["o"] + 1)
    return pol, "o_norm.sum"


def _in_dim(pol):
    pol["norm"]["o"] += 1
    return pol, "in_dim"


def _no_key(pol):
    del pol["norm"]
    return pol, "norm"


def _not_a_number(pol):
    pol["shape"]["layers"] = "3"
    return pol, "layers"


def _nan_weight(pol):  # a diverged run: its actions would be NaN
    pol["actor"]["net.2.weight"][3, 5] = float("nan")
    return pol, "net.2.weight holds 1 of 65536 values NaN or infinite"


def _inf_norm(pol):  # the normaliser's sums overflowed
    pol["g_norm"]["sumsq"][0] = np.inf
    return pol, "g_norm.sumsq holds 1 of 3 values NaN or infinite"


BROKEN_POLICIES = [
    _wrong_actor,
    _missing_layer,
    _wrong_record,
    _wrong_norm,
    _in_dim,
    _no_key,
    _not_a_number,
    _nan_weight,
    _inf_norm,
]


@pytest.mark.parametrize(
    "breakit", BROKEN_POLICIES, ids=lambda f: f.__name__.strip("_")
)
def test_a_policy_that_does_not_fit_its_record_is_refused_before_building(
    tmp_path, breakit
):
    pol, needle = breakit(_policy())
    path = str(tmp_path / "policy.pt")
    torch.save(dict(policy=pol), path)
    with pytest.raises(CheckpointError) as e:
        load_torch(path)
    assert (
        "\n" not in str(e.value) and path in str(e.value) and needle in str(e.value)
    ), str(e.value)
    with pytest.raises(CheckpointError) as e:  # the Python API, from a dict
        Policy.from_state_dict(pol)
    assert needle in str(e.value)


def test_eval_refuses_files_that_are_not_ours(tmp_path, cli):
    cases = []
    torch.save(torch.zeros(3), tmp_path / "tensor.pt")
    cases.append(("tensor.pt", "Tensor"))
    torch.save({"weights": torch.zeros(3)}, tmp_path / "dict.pt")
    cases.append(("dict.pt", "'policy'"))
    pol, _ = _wrong_actor(_policy())
    torch.save(dict(policy=pol), tmp_path / "shape.pt")
    cases.append(("shape.pt", "net.0.weight"))
    (tmp_path / "truncated.pt").write_bytes(open(REACH, "rb").read()[:4000])
    cases.append(("truncated.pt", "truncated"))
    pol = _policy()
    pol["env"] = "FetchPush-v4"  # a Reach policy (10 + 3 inputs) on Push (25 + 3)
    torch.save(dict(policy=pol), tmp_path / "other-env.pt")
    cases.append(("other-env.pt", "10/3/4"))
    pol = _policy()
    pol["env"] = "../../etc/passwd"
    torch.save(dict(policy=pol), tmp_path / "env.pt")
    cases.append(("env.pt", "FetchReach-v4"))
    pol, _ = _nan_weight(_policy())
    torch.save(dict(policy=pol), tmp_path / "nan.pt")
    cases.append(("nan.pt", "diverged"))
    for name, needle in cases:
        one_line(
            cli("eval", "--checkpoint", str(tmp_path / name), "--episodes", "1"),
            name,
            needle,
        )
    # export: a NaN controller is not written for a robot
    out = tmp_path / "nan.ts"
    one_line(cli("export", str(tmp_path / "nan.pt"), "--out", str(out)), "diverged")
    assert not out.exists()


def test_an_incomplete_checkpoint_is_refused(tmp_path, fresh):
    ck = load_torch(os.path.join(fresh["acder"], "checkpoint.pt"))
    del ck["rng"]
    path = str(tmp_path / "checkpoint.pt")
    torch.save(ck, path)
    with pytest.raises(CheckpointError, match="rng"):
        load_torch(path)


# ----- our own files keep loading


def test_every_committed_policy_loads_safely():
    assert len(COMMITTED) >= 40
    for path in COMMITTED:
        pol = load_torch(path)["policy"]
        p = Policy.from_state_dict(pol)
        o, g = (
            np.zeros((2, pol["norm"]["o"]), np.float32),
            np.zeros((2, pol["norm"]["g"]), np.float32),
        )
        assert p(o, g).shape == (2, pol["shape"]["act_dim"])


def test_eval_runs_a_committed_policy(cli):
    p = cli("eval", "--checkpoint", REACH, "--episodes", "1")
    assert p.returncode == 0, p.stderr
    assert "episodes=1" in p.stdout and "success_rate=" in p.stdout


@pytest.fixture(scope="module")
def fresh(tmp_path_factory):
    """One-epoch runs whose checkpoints hold every part: S-ICM and the start pool
    (acder), the PER sum tree (her-per), the trajectory energies (her-ebp)."""
    out = {}
    for method, env in (
        ("acder", "FetchReach-v4"),
        ("her-per", "FetchPush-v4"),
        ("her-ebp", "FetchPush-v4"),
    ):
        d = str(tmp_path_factory.mktemp(method))
        tr = Trainer(tiny_config(env=env, method=method, epochs=1, cycles=2), d)
        tr.train(progress=False)
        out[method] = d
        out[method + ":trainer"] = tr
    return out


def _same(a, b, where="") -> None:
    assert type(a) is type(b), (where, type(a), type(b))
    if isinstance(a, dict):
        assert list(a) == list(b), where
        for k in a:
            _same(a[k], b[k], f"{where}.{k}")
    elif isinstance(a, (list, tuple)):
        assert len(a) == len(b), where
        for i, (x, y) in enumerate(zip(a, b)):
            _same(x, y, f"{where}[{i}]")
    elif isinstance(a, np.ndarray):
        assert (
            a.dtype == b.dtype
            and a.shape == b.shape
            and np.array_equal(a, b, equal_nan=True)
        ), where
    elif isinstance(a, torch.Tensor):
        assert a.dtype == b.dtype and torch.equal(a, b), where
    elif isinstance(a, float) and np.isnan(a):
        assert np.isnan(b), where
    else:
        assert a == b, where


@pytest.mark.parametrize("method", ["acder", "her-per", "her-ebp"])
def test_a_fresh_checkpoint_loads_safely_and_whole(fresh, method):
    tr = fresh[method + ":trainer"]
    path = os.path.join(fresh[method], "checkpoint.pt")
    ck = load_torch(path)
    # our own file: the unsafe way gives the same, whole (its arrays stored as tensors)
    raw = torch.load(path, weights_only=False)
    assert isinstance(raw["buffer"]["state"][aio.NUMPY_TAG], torch.Tensor)
    _same(ck, aio.tensors_as_arrays(raw))
    _same(ck["buffer"], tr.buffer.state_dict())  # the arrays, bit for bit
    assert set(aio.CHECKPOINT_KEYS) <= set(ck)
    assert (
        str(ck["versions"]["torch"]) == torch.__version__
    )  # a TorchVersion, allowed by name
    # numpy's PCG64 state: Python ints of 128 bits, carried as they are
    st = ck["rng"]["numpy"]
    assert (
        st["bit_generator"] == "PCG64"
        and max(st["state"]["state"], st["state"]["inc"]) > 2**64
    )
    assert np.array_equal(
        np.random.Generator(_pcg(st)).random(5),
        np.random.Generator(_pcg(tr.rng.bit_generator.state)).random(5),
    )
    # the policy rebuilt from policy.pt acts exactly as the trainer's
    pol = load_torch(os.path.join(fresh[method], "policy.pt"))["policy"]
    p = Policy.from_state_dict(pol)
    rng = np.random.default_rng(0)
    o = rng.normal(size=(3, pol["norm"]["o"])).astype(np.float32)
    goal = rng.normal(size=(3, pol["norm"]["g"])).astype(np.float32)
    assert np.array_equal(p(o, goal), tr.policy(o, goal))


def _pcg(state):
    bg = np.random.PCG64()
    bg.state = state
    return bg


def test_only_the_named_globals_are_needed(fresh):
    """What the files name beyond torch's own safe set is exactly what SAFE_GLOBALS
    allows, by name."""
    allowed = {
        name if isinstance(g, tuple) else f"{g.__module__}.{g.__qualname__}"
        for g in aio.SAFE_GLOBALS
        for name in ([g[1]] if isinstance(g, tuple) else [None])
    }
    seen = set()
    files = COMMITTED + [
        os.path.join(fresh[m], f)
        for m in ("acder", "her-per", "her-ebp")
        for f in ("checkpoint.pt", "policy.pt")
    ]
    for path in files:
        seen |= set(torch.serialization.get_unsafe_globals_in_checkpoint(path))
    assert seen <= allowed, seen - allowed


def test_diagnose_reads_a_fresh_checkpoint(fresh):
    from acder_lite.cli import diagnose as D

    d = D.diagnose(fresh["acder"], batches=1)
    assert d["method"] == "acder" and "curiosity" in d


# ----- local servers listen on 127.0.0.1 only


def test_meshcat_listens_on_localhost_only():
    import meshcat  # noqa: F401  (pinned in requirements.txt: missing is a failure)

    from acder_lite.book import viz

    vis = viz.new_visualizer()  # a server that cannot start is a failure, not a skip
    try:
        pid = vis.window.server_proc.pid
        socks = []
        for _ in range(
            20
        ):  # the web server is up before the zmq url is printed; be patient anyway
            socks = _listening(pid)
            if len(socks) >= 2:
                break
            time.sleep(0.1)
        assert len(socks) >= 2, socks  # ZeroMQ and the web page
        assert all(ip in ("127.0.0.1", "::1") for ip, _ in socks), socks
        assert vis.window.web_url.startswith("http://127.0.0.1:")
    finally:
        viz.close_visualizer(vis)


@pytest.mark.parametrize("kind", ["torch-system", "policy-only"])
def test_resume_refuses_a_file_that_is_not_a_training_state(tmp_path, cli, kind):
    """train --resume DIR on a crafted checkpoint.pt, or on a policy.pt renamed:
    one line, exit 2."""
    marker = tmp_path / "marker"
    run = tmp_path / "run"
    run.mkdir()
    if kind == "policy-only":
        (run / "checkpoint.pt").write_bytes(open(REACH, "rb").read())
    else:
        os.replace(_crafted(tmp_path, kind, marker), run / "checkpoint.pt")
    one_line(cli("train", "--resume", str(run)), "checkpoint.pt")
    assert not marker.exists() and sorted(p.name for p in run.iterdir()) == [
        "checkpoint.pt"
    ]


# ----- checkpoint.pt stores numpy arrays as tensors (io.arrays_as_tensors)


def test_arrays_as_tensors_round_trip_bit_for_bit(tmp_path):
    """Arrays of every dtype a checkpoint holds come back equal in dtype, shape and
    bits (NaN, -0.0 and float64 tails included); tensors, numbers, strings and a torch
    state_dict's metadata are left as they are; an old file (arrays pickled) reads
    the same."""
    from collections import OrderedDict

    sd = OrderedDict(w=torch.arange(3.0))
    sd._metadata = OrderedDict({"": {"version": 1}})
    rng = np.random.default_rng(0)
    obj = dict(
        policy=dict(actor=sd),
        buffer=dict(
            o=rng.normal(size=(4, 3, 2)).astype(np.float32),
            state=np.array([[np.nan, -0.0, 1 / 3, np.finfo(np.float64).tiny]]),
            success=np.array([True, False]),
            idx=np.arange(5, dtype=np.int64)[::-2],  # a strided view
            big=rng.normal(size=(1000, 64)),  # where pickling's latin-1 text shows
            n=4,
        ),
        rows=[dict(a=1.5)],
        pair=(np.zeros(2, np.float32), "x"),
    )
    enc = aio.arrays_as_tensors(obj)
    assert isinstance(enc["buffer"]["o"][aio.NUMPY_TAG], torch.Tensor)
    assert enc["policy"] is obj["policy"] and enc["rows"] is obj["rows"]
    assert obj["buffer"]["success"].dtype == bool  # the input is not changed
    new, old = str(tmp_path / "new.pt"), str(tmp_path / "old.pt")
    aio.save_torch(new, enc)
    aio.save_torch(old, obj)
    for path in (new, old):
        back = aio.tensors_as_arrays(torch.load(path, weights_only=False))
        _same(back, obj)
        for k, a in obj["buffer"].items():
            if isinstance(a, np.ndarray):
                assert back["buffer"][k].tobytes() == a.tobytes(), k
        assert back["policy"]["actor"]._metadata == sd._metadata
    assert os.path.getsize(new) < 0.8 * os.path.getsize(old)


def test_a_checkpoint_of_the_old_layout_still_resumes(tmp_path):
    """A checkpoint.pt written before arrays were stored as tensors (the runs in
    flight when it changed) loads into the same trainer state, and the run resumed
    from it ends as the uninterrupted run does."""
    kw = dict(env="FetchPush-v4", method="acder", epochs=2)
    full, part = tmp_path / "full", tmp_path / "part"
    Trainer(tiny_config(**kw), str(full)).train(progress=False)
    tr = Trainer(tiny_config(**kw), str(part))
    tr.train(progress=False, max_cycles=tr.cfg.cycles)  # the first epoch only
    path = str(part / "checkpoint.pt")
    ck = load_torch(path)
    aio.save_torch(path, ck)  # arrays pickled as numpy arrays, as before
    assert isinstance(torch.load(path, weights_only=False)["buffer"]["o"], np.ndarray)
    again = load_torch(path)
    _same(again, ck)
    t2 = Trainer(tiny_config(**kw), str(part))
    t2.load_state_dict(again)
    _same(t2.buffer.state_dict(), tr.buffer.state_dict())
    t2.train(progress=False)
    assert len(rows_of(full / "progress.csv")) > len(ck["progress"]["rows"])  # on
    assert rows_of(part / "progress.csv") == rows_of(full / "progress.csv")


def test_an_exported_torchscript_file_is_named_as_one(tmp_path, cli):
    """export's TorchScript file given where a policy.pt is read (eval, robust, export,
    --resume's checkpoint.pt): one line saying what it is and what is allowed, not
    'truncated or not a checkpoint'."""
    from acder_lite.deploy.export import export_torchscript

    ts = tmp_path / "push.ts"
    export_torchscript(_policy(), str(ts), REACH)
    with pytest.raises(CheckpointError, match="TorchScript file written by export"):
        load_torch(str(ts))
    assert not aio.is_torchscript(REACH)  # torch.save's archive is not one
    want = ["'" + str(ts) + "'", "TorchScript file written by export", "policy.pt"]
    one_line(cli("eval", "--checkpoint", str(ts), "--episodes", "1"), *want)
    one_line(cli("robust", str(ts)), *want)
    one_line(cli("export", str(ts), "--out", str(tmp_path / "again.ts")), *want)
    assert not (tmp_path / "again.ts").exists()


def test_a_dict_holding_arrays_keeps_its_type_and_metadata():
    """A dict that holds an array is rebuilt around the array's tensor: it keeps its
    type and what a torch state_dict carries beside its items (`_metadata`), on the way
    in and on the way back."""
    from collections import OrderedDict

    sd = OrderedDict(w=np.arange(3.0), n=2)
    sd._metadata = OrderedDict({"": {"version": 2}})
    enc = aio.arrays_as_tensors(dict(s=sd))
    assert isinstance(enc["s"]["w"][aio.NUMPY_TAG], torch.Tensor)
    assert type(enc["s"]) is OrderedDict and enc["s"]._metadata == sd._metadata
    back = aio.tensors_as_arrays(enc)
    assert type(back["s"]) is OrderedDict and back["s"]._metadata == sd._metadata
    assert back["s"]["w"].tobytes() == sd["w"].tobytes() and back["s"]["n"] == 2


def test_file_in_the_way_names_the_nearest_path_that_is_not_a_folder(tmp_path):
    """`io.file_in_the_way`, which train --out, sweep, a plan's same_as and every
    output file ask: the nearest existing path at (or only above) a path, if a file."""
    (tmp_path / "f").write_text("x")
    (tmp_path / "d").mkdir()
    assert aio.file_in_the_way(tmp_path / "f") == str(tmp_path / "f")
    assert aio.file_in_the_way(tmp_path / "f", itself=False) is None
    assert aio.file_in_the_way(tmp_path / "f" / "a" / "b") == str(tmp_path / "f")
    assert aio.file_in_the_way(tmp_path / "d" / "new" / "x") is None
    assert aio.file_in_the_way(tmp_path / "d") is None
