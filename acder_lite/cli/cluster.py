"""Where a sweep's cells run: a local Ray of the sweep's own, or a running Ray cluster.

Without `--address`, `connect` starts a Ray on this machine (`--jobs` x `--threads`
CPUs) that ends with the sweep. With `--address auto` or `--address HOST:PORT` (the
head's GCS port, 6379 unless `ray start --port` said otherwise) the sweep joins a
running cluster as a driver, so it must run on a node of that cluster; the results
folder must be storage every node sees at the same path.

Not Ray Client (`ray://HOST:PORT`): a sweep lasts days and must outlive any one
connection, which a Ray Client driver does not (its workload ends when the connection
drops), and Ray Client's server forks under gRPC threads (ray-project/ray#63202). Run
the sweep on a node of the cluster instead (over ssh, under nohup or tmux).

Trap: a cluster with token authentication (`ray start` turns it on with
`RAY_AUTH_MODE=token`, or when it finds a token file) refuses a driver that joins it by
an explicit address (`HOST:PORT`, or RAY_ADDRESS behind `auto`) without the token, and
Ray 2.60 sends none unless `RAY_AUTH_MODE=token` is set: it turns that on by itself only
for a cluster it finds on its own, and only when a token file exists. Refused, Ray's C++
client retries for about 20 s, printing a line a second straight to file descriptor 2;
`connect` holds those lines and `join_problem` turns them into one line that says what
to set.
"""

from __future__ import annotations

import contextlib
import os
import socket
import sys
import tempfile
from pathlib import Path

START_ATTEMPTS = 3
"""How often the sweep tries to start its local Ray (each try has Ray's own 30 s)."""

CONNECT_TIMEOUT_S = 5.0
"""How long `--address HOST:PORT` may take to answer before the sweep gives
up (exit 2)."""


def check_address(address: str) -> str | None:
    """None if something answers at `address` ('auto' is left to Ray), else one line."""
    if address == "auto":
        return None
    if "://" in address:
        return (
            f"--address={address!r} is not allowed: 'auto' or HOST:PORT (the head's "
            "GCS port), from a node of the cluster; Ray Client (ray://) is not "
            "installed, and a sweep must outlive a client's connection"
        )
    host, _, port = address.rpartition(":")
    if not host or not port.isdigit():
        return f"--address={address!r} is not allowed: 'auto' or HOST:PORT"
    try:
        socket.create_connection((host, int(port)), timeout=CONNECT_TIMEOUT_S).close()
    except OSError as e:
        return (
            f"--address={address!r} does not answer within "
            f"{CONNECT_TIMEOUT_S:g} s ({e.strerror or e})"
        )
    return None


def first_line(error: BaseException) -> str:
    """The first line of an error's message, or its type's name when it has none
    (Ray's errors run to pages; a sweep's refusal is one line)."""
    return (str(error).splitlines() or [type(error).__name__])[0]


class Refused(Exception):
    """The cluster at `--address` could not be joined; the message is one line."""


def join_problem(address: str, error: Exception, ray_said: str) -> str:
    """One line for a failed join: what Ray raised, and what its C++ client printed."""
    if type(error).__name__ == "AuthenticationError" or "no authentication token" in (
        str(error)
    ):  # RAY_AUTH_MODE=token, and Ray found no token to send
        return (
            f"--address={address!r}: RAY_AUTH_MODE=token but no token here: give "
            "the cluster's (RAY_AUTH_TOKEN, RAY_AUTH_TOKEN_PATH or the file "
            "~/.ray/auth_token)"
        )
    if "InvalidAuthToken" in ray_said or "InvalidAuthToken" in str(error):
        # case-blind, as Ray reads it (ray/_private/authentication/
        # authentication_token_setup.py: `auth_mode_env.lower() == "token"`)
        if os.environ.get("RAY_AUTH_MODE", "").lower() == "token":
            return (
                f"--address={address!r}: the cluster refused this sweep's token "
                "(RAY_AUTH_TOKEN, RAY_AUTH_TOKEN_PATH or ~/.ray/auth_token, in that "
                "order, must hold the cluster's)"
            )
        return (
            f"--address={address!r}: the cluster asks for its token: set "
            "RAY_AUTH_MODE=token and give the cluster's token (RAY_AUTH_TOKEN, or the "
            "file ~/.ray/auth_token)"
        )
    return f"--address={address!r}: no Ray cluster there ({first_line(error)[:160]})"


@contextlib.contextmanager
def _fd2_held():
    """Send file descriptor 2 to a temporary file for the block; yields a dict whose
    "text" is what was written there, once the block has ended."""
    sys.stderr.flush()
    saved = os.dup(2)
    held = {"text": ""}
    with tempfile.TemporaryFile() as f:
        os.dup2(f.fileno(), 2)
        try:
            yield held
        finally:
            sys.stderr.flush()
            os.dup2(saved, 2)
            os.close(saved)
            f.seek(0)
            held["text"] = f.read().decode(errors="replace")


def connect(address: str | None, cpus: int, say=print):
    """Start a local Ray of `cpus` CPUs (`address` None), or join the cluster at
    `address`; raises `Refused` (one line) when that cluster cannot be joined."""
    import ray

    os.environ.setdefault("RAY_DEDUP_LOGS", "0")
    quiet = dict(
        include_dashboard=False,
        log_to_driver=False,
        configure_logging=True,
        logging_level="ERROR",
    )
    # The package must be importable in the workers from any cwd
    # (a test runs the sweep elsewhere).
    root = str(Path(__file__).resolve().parents[2])  # acder_lite/cli/cluster.py
    runtime_env = {
        "env_vars": {"PYTHONPATH": root + os.pathsep + os.environ.get("PYTHONPATH", "")}
    }
    if address:
        with _fd2_held() as held:
            try:
                ctx = ray.init(address=address, runtime_env=runtime_env, **quiet)
                error = None
            except Exception as e:  # Ray's kinds vary (ConnectionError, ...): any
                error = e  # is a refusal, and the held lines must not be lost
        if error is not None:
            raise Refused(join_problem(address, error, held["text"])) from None
        sys.stderr.write(held["text"])  # a joined cluster's messages, if any
        return ctx
    # address="local": always a Ray of our own (without it ray.init may join a cluster
    # that `ray start` left running, or RAY_ADDRESS names). Trap: Ray gives its raylet a
    # fixed 30 s to register (node.py), which a machine busy with training can
    # miss: try again.
    for attempt in range(1, START_ATTEMPTS + 1):
        try:
            return ray.init(
                address="local",
                num_cpus=cpus,
                object_store_memory=100 * 2**20,
                runtime_env=runtime_env,
                **quiet,
            )
        except Exception as e:  # Ray raises a bare Exception for this
            if "timed out during startup" not in str(e) or attempt == START_ATTEMPTS:
                raise
            ray.shutdown()
            say(
                f"the local Ray did not start in time (attempt {attempt} of "
                f"{START_ATTEMPTS}); trying again"
            )
