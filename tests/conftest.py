import os
import subprocess
import sys

import pytest

from acder_lite.config import Config

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def tiny_config(**kw) -> Config:
    """A configuration small enough for a unit test;
    same code path as the paper protocol."""
    base = dict(
        env="FetchReach-v4",
        method="her",
        workers=1,
        epochs=2,
        cycles=3,
        updates_per_cycle=4,
        batch_size=32,
        test_episodes=1,
        hidden=32,
        sicm_hidden=32,
        buffer_size=20_000,
        threads=1,
    )
    base.update(kw)
    return Config(**base)


def stop_tree(proc: subprocess.Popen, also=(), timeout: float = 30) -> None:
    """Stop `proc` and every process under it (and the pids in `also`): terminate the
    parent first, so it can shut down cleanly, then kill what it left behind. The trap:
    children must be listed before the parent exits, or they are reparented and lost."""
    import psutil

    try:
        pids = {p.pid for p in psutil.Process(proc.pid).children(recursive=True)}
    except psutil.Error:
        pids = set()
    pids.update(also)
    if proc.poll() is None:
        proc.terminate()
        try:
            proc.wait(timeout=timeout)
        except subprocess.TimeoutExpired:
            proc.kill()
            proc.wait()
    for pid in pids:
        try:
            psutil.Process(pid).kill()
        except psutil.Error:
            pass


def rows_of(path) -> list[dict]:
    """A run's progress.csv rows as text, without the one column that differs between
    two runs computing the same numbers (wall_s)."""
    import csv

    with open(path) as f:
        return [
            {k: v for k, v in r.items() if k != "wall_s"} for r in csv.DictReader(f)
        ]


def curve_cell(name: str, values, env="FetchPush-v4", ended="budget", seeds=2):
    """A cell of `seeds` equal seeds whose test success at epochs 1, 2, ... is `values`
    (400 episodes an epoch, a budget of len(values) epochs), through report.cell_stat:
    for Table I's text cells (table) and the book's computations (findings)."""
    from acder_lite.stats.report import cell_stat

    rows = [
        dict(epoch=float(i), episodes=400.0 * i, test_success=v)
        for i, v in enumerate(values, 1)
    ]
    r = dict(
        env=env,
        name=name,
        method=name,
        seed=0,
        rows=rows,
        ended=ended,
        budget_epochs=float(len(values)),
        episodes_per_epoch=400.0,
        update_dtype="float32",
    )
    return cell_stat(env, name, [dict(r, seed=i) for i in range(seeds)], n_boot=100)


def her_acder_cells():
    """DDPG+HER and DDPG+ACDER cells (`curve_cell`) crossing 95% at 2.9 and 1.9 epochs
    (2 + 0.45 / 0.5, 1 + 0.45 / 0.5): the pair the sentences' tests read."""
    return (
        curve_cell("her", [0.0, 0.5, 1.0, 1.0]),
        curve_cell("acder", [0.5, 1.0, 1.0, 1.0]),
    )


def push_cell(name: str, crossing, low, high):
    """A FetchPush CellStat with only a mean-curve crossing and its interval (epochs),
    for the readings' rule (report.choose)."""
    from acder_lite.stats.report import CellStat

    return CellStat(
        env="FetchPush-v4", name=name, method="acder", threshold=0.95,
        episodes_per_epoch=400.0, crossing=crossing, low=low, high=high,
    )  # fmt: skip


def networks(tr) -> list:
    """Every network a trainer holds: actor, critic, their targets, and the curiosity
    model (None for methods without one)."""
    a = tr.agent
    return [a.actor, a.critic, a.actor_targ, a.critic_targ, tr.curiosity]


def assert_same_run(a, b, rows=True) -> None:
    """Two trainers that ran the same computation, at full precision: every progress
    row as floats (wall_s aside; `rows=False` skips them), every tensor of the agent's
    actor, critic and both targets and of the curiosity module where there is one, the
    replay buffer's arrays, and the numpy random stream's state."""
    import numpy as np
    import torch

    if rows:
        strip = [
            [{k: v for k, v in r.items() if k != "wall_s"} for r in t.rows]
            for t in (a, b)
        ]
        assert strip[0] == strip[1] and strip[0]
    net_a, net_b = a.agent.state_dict(), b.agent.state_dict()
    for net in ("actor", "critic", "actor_targ", "critic_targ"):
        assert net_a[net].keys() == net_b[net].keys()
        for k, v in net_a[net].items():
            assert torch.equal(v, net_b[net][k]), f"{net}.{k}"
    assert (a.curiosity is None) == (b.curiosity is None)
    if a.curiosity is not None:
        cur_b = b.curiosity.state_dict()
        for k, v in a.curiosity.state_dict().items():
            assert torch.equal(v, cur_b[k]), f"curiosity.{k}"
    buf_a, buf_b = a.buffer.arrays(), b.buffer.arrays()
    assert buf_a.keys() == buf_b.keys()
    for key in buf_a:
        np.testing.assert_array_equal(buf_a[key], buf_b[key], err_msg=key)
    assert a.rng.bit_generator.state == b.rng.bit_generator.state


def run_cli(*args, timeout=300, **kw):
    env = dict(os.environ, PYTHONPATH=ROOT)
    return subprocess.run(
        [sys.executable, "-m", "acder_lite", *args],
        capture_output=True,
        text=True,
        timeout=timeout,
        cwd=ROOT,
        env=env,
        **kw,
    )


@pytest.fixture
def cli():
    return run_cli


def listening(pid: int) -> list[tuple[str, int]]:
    """(address, port) of the TCP sockets process `pid` listens on
    (as in test_safe_loading)."""
    try:
        import psutil
    except ImportError:
        psutil = None
    if psutil is not None:
        try:
            return [
                (c.laddr.ip, c.laddr.port)
                for c in psutil.Process(pid).net_connections(kind="inet")
                if c.status == psutil.CONN_LISTEN
            ]
        except psutil.NoSuchProcess:
            return []
    if not os.path.isdir(f"/proc/{pid}/fd"):
        pytest.skip("neither psutil nor /proc to read listening sockets")
    inodes = set()
    for fd in os.listdir(f"/proc/{pid}/fd"):
        try:
            link = os.readlink(f"/proc/{pid}/fd/{fd}")
        except OSError:
            continue
        if link.startswith("socket:["):
            inodes.add(link[8:-1])
    out = []
    for table, v6 in (("/proc/net/tcp", False), ("/proc/net/tcp6", True)):
        if not os.path.exists(table):
            continue
        for line in open(table).read().splitlines()[1:]:
            f = line.split()
            if f[3] != "0A" or f[9] not in inodes:  # 0A: LISTEN
                continue
            hexip, hexport = f[1].split(":")
            raw = bytes.fromhex(hexip)
            if v6:
                import ipaddress

                words = b"".join(raw[i : i + 4][::-1] for i in range(0, 16, 4))
                ip = str(ipaddress.IPv6Address(words))
            else:
                ip = ".".join(str(b) for b in raw[::-1])
            out.append((ip, int(hexport, 16)))
    return out


def rewards_of(tr, batch: dict, tb: dict | None = None):
    """The critic's rewards for `batch` as `Trainer.update_step` computes them, with the
    same side effects in the same order (the curiosity model's step, the logged mean
    lambda, the start-state offer), as a numpy array."""
    tb = tr.batch_tensors(batch) if tb is None else tb
    r_int = tr.curiosity_step(batch, tb)
    r, lam = tr.shaped_rewards(batch, r_int)
    if lam is not None:
        tr.diag["lam"] += float(lam.mean())
    tr.offer_start_states(batch, r_int)
    return r
