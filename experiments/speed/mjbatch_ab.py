"""mjbatch (MuJoCo batches stepped on a C++ thread pool, on the package index) against
the envs' physics stepped as `rollout.StepPool` steps them, and sequentially: 4
FetchPush-v4 models, 2 threads, interleaved rounds of one 50-step episode of the 4 envs;
and whether mjbatch's states equal mj_step's bit for bit.

mjbatch is not a dependency: run this in a venv of its own, never the project's. Its
releases are built each for one mujoco: 0.1.0 for 3.11.0 (the project's pin), 0.1.1 and
0.1.2 for 3.13.0, 0.1.3 and 0.1.4 for 3.14.0 (on which gymnasium-robotics 1.4.2 cannot
make a Fetch env, DESIGN.md). So two ways, from the repository root:

    # mjbatch 0.1.0 on the project's mujoco 3.11.0: the real envs, reset by our code
    python -m venv /tmp/mjbvenv311
    /tmp/mjbvenv311/bin/pip install mujoco==3.11.0 numpy==2.4.6 && \
        /tmp/mjbvenv311/bin/pip install --no-deps mjbatch==0.1.0
    echo $PWD/.venv/lib/python3.11/site-packages > \
        /tmp/mjbvenv311/lib/python3.11/site-packages/zz_project.pth
    PYTHONPATH=$PWD /tmp/mjbvenv311/bin/python experiments/speed/mjbatch_ab.py \
        --dump /tmp/push_states.npz      # also writes the 4 start states
    # mjbatch 0.1.4 on mujoco 3.14.0: the same model file, the start states above
    (a venv the same way with mujoco==3.14.0 and mjbatch==0.1.4)
    PYTHONPATH=$PWD /tmp/mjbvenv/bin/python experiments/speed/mjbatch_ab.py \
        --states /tmp/push_states.npz

What is stepped, the same in every way: the physics of `envs.step` with random actions
(`bench`'s), i.e. per env step `fastobs._set_action`'s writes (the mocap to the gripper
body plus 0.05 x the action, the rotation, the fingers' ctrl), `mj_step` x 20
(n_substeps), the fingers' qpos to 0 and `mj_forward` (`_step_callback`). envs.step's
second `mj_forward` changes no number (the state is the same) and is left out of every
way. Not stepped: the observation's Python (`_get_obs`, 52 us an env step), which stays
Python under the GIL whatever steps the physics. On mujoco 3.11 the sequential way is
first checked against the real envs' `envs.step` (the same qpos and qvel bit for bit),
and the model `--states` runs on against the envs' own (the same states).

- `sequential`: the 4 envs one after the other in this thread;
- `step_pool`: `rollout.StepPool(2)` (this thread and one helper, 2 envs each);
- `mjbatch-1`, `mjbatch-2`: one `Batch` of the 4, on 1 and 2 threads of its pool:
  the writes into its bound arrays (all 4 at once, numpy), `step(nstep=20)`, the
  fingers, `forward()`;
- `unsynced`: not a way to roll out, the machine's headroom: the StepPool's 2 threads
  each stepping its 2 envs through the whole episode, no barrier between steps.

Prints wall and CPU (process_time, every thread) ms per episode of the 4 envs, by
round and the medians, each way's ratio to sequential, and after every round whether
each way's final states (mjSTATE_INTEGRATION: qpos, qvel, warm start, ...) equal
sequential's bit for bit.
"""

import argparse
import importlib.metadata
import importlib.util
import os
import statistics as st
import sys
import time

import mujoco
import numpy as np

import mjbatch
from acder_lite.train.rollout import StepPool

N, T, SUB, THREADS = 4, 50, 20, 2
ROT = np.array([1.0, 0.0, 1.0, 0.0])
FINGERS = ("robot0:l_gripper_finger_joint", "robot0:r_gripper_finger_joint")
# named fields that make up a start state (what mj_resetData leaves at 0 is 0)
FIELDS = ("qpos", "qvel", "act", "ctrl", "mocap_pos", "mocap_quat", "qacc_warmstart")
SPEC = mujoco.mjtState.mjSTATE_INTEGRATION


def push_xml() -> str:
    """gymnasium-robotics' FetchPush model file (found without importing it)."""
    where = importlib.util.find_spec("gymnasium_robotics").submodule_search_locations
    return os.path.join(where[0], "envs", "assets", "fetch", "push.xml")


def push_model():
    """The model as gymnasium-robotics' env holds it: the file, then its `_env_setup`'s
    `reset_mocap_welds` (every weld's relative pose to identity: without it the mocap
    weld pulls the gripper to an offset and the solver works 2-3x longer a step)."""
    m = mujoco.MjModel.from_xml_path(push_xml())
    for i in range(m.neq):
        if m.eq_type[i] == mujoco.mjtEq.mjEQ_WELD:
            m.eq_data[i, :7] = [0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 1.0]
    return m


def real_envs():
    """4 FetchPush envs as the trainer makes them (seeds 0-3), reset; None where
    gymnasium-robotics cannot make one (mujoco >= 3.12), with why."""
    try:
        from acder_lite.envs import fetch as E

        envs = [E.make_env("FetchPush-v4", seed=i) for i in range(N)]
    except Exception as e:  # the mujoco 3.14 venv: an AssertionError, no message
        import traceback

        where = traceback.extract_tb(e.__traceback__)[-1]
        return None, f"make_env: {type(e).__name__} in {where.name} ({where.line})"
    for env in envs:
        env.reset()
    return envs, ""


class Layout:
    """What `_set_action` and `_step_callback` address in the model."""

    def __init__(self, m):
        self.ctrl = []  # (actuator, qpos address or -1): position actuators relative
        for i in range(m.nu):
            rel = m.actuator_biastype[i] != 0
            self.ctrl.append(
                (i, int(m.jnt_qposadr[m.actuator_trnid[i, 0]]) if rel else -1)
            )
        self.welds = []  # (mocap, body), every weld in the model's order
        for eq_type, a, b in zip(m.eq_type, m.eq_obj1id, m.eq_obj2id):
            if eq_type == mujoco.mjtEq.mjEQ_WELD:
                mocap, body = m.body_mocapid[a], b
                if mocap == -1:
                    mocap, body = m.body_mocapid[b], a
                self.welds.append((int(mocap), int(body)))
        self.fingers = [int(m.jnt_qposadr[m.joint(n).id]) for n in FINGERS]


def deltas(rng) -> np.ndarray:
    """(T, N, 3) mocap moves: 0.05 x random actions in float32, as _set_action
    computes them (`pos_ctrl *= 0.05` on the float32 action), then float64."""
    a = rng.uniform(-1, 1, (T, N, 4)).astype(np.float32)
    return (a[..., :3] * np.float32(0.05)).astype(np.float64)


def env_step(m, d, lay, du):
    """One env step's physics, in `fastobs._set_action`'s and `_step_callback`'s
    order and arithmetic (the gripper's ctrl 0: Push blocks the gripper)."""
    for i, adr in lay.ctrl:
        d.ctrl[i] = 0.0 if adr < 0 else d.qpos[adr] + 0.0
    for mocap, body in lay.welds:
        d.mocap_pos[mocap][:] = d.xpos[body]
        d.mocap_quat[mocap][:] = d.xquat[body]
    d.mocap_pos[:] = d.mocap_pos + du
    d.mocap_quat[:] = d.mocap_quat + ROT
    mujoco.mj_step(m, d, nstep=SUB)
    d.qpos[lay.fingers] = 0.0
    mujoco.mj_forward(m, d)


def get_state(m, d) -> np.ndarray:
    s = np.empty(mujoco.mj_stateSize(m, SPEC))
    mujoco.mj_getState(m, d, s, SPEC)
    return s


class Plain:
    """The 4 envs' MjData, stepped in this thread or by a StepPool."""

    def __init__(self, m, lay, pool=None):
        self.m, self.lay, self.pool = m, lay, pool
        self.data = [mujoco.MjData(m) for _ in range(N)]

    def load(self, states):
        for d, s in zip(self.data, states):
            mujoco.mj_setState(self.m, d, s, SPEC)
            mujoco.mj_forward(self.m, d)

    def episode(self, du):
        envs = list(range(N))
        for t in range(T):

            def one(i, t=t):
                env_step(self.m, self.data[i], self.lay, du[t, i])

            if self.pool is None:
                for i in envs:
                    one(i)
            else:
                self.pool.run(one, envs)

    def states(self):
        return [get_state(self.m, d) for d in self.data]


class Unsynced(Plain):
    """The machine's headroom, not a rollout: 2 threads each stepping its 2 envs
    through all 50 steps with no barrier between steps (a policy acting on all 4 at
    every step needs one)."""

    def episode(self, du):
        def share(k):
            for t in range(T):
                for i in range(k, N, THREADS):
                    env_step(self.m, self.data[i], self.lay, du[t, i])

        self.pool.run(share, list(range(THREADS)))


class Batched:
    """The 4 as one mjbatch.Batch: the same writes, on its bound arrays."""

    def __init__(self, m, lay, threads):
        self.lay = lay
        self.b = mjbatch.Batch(m, N, num_threads=threads)
        bind = self.b.bind
        self.state = bind("state")
        self.qpos, self.ctrl = bind("qpos"), bind("ctrl")
        self.mocap_pos, self.mocap_quat = bind("mocap_pos"), bind("mocap_quat")
        self.xpos, self.xquat = bind("xpos"), bind("xquat")

    def load(self, states):
        self.state[:] = np.stack(states)
        self.b.forward()  # derived fields (xpos) for the first step's writes

    def episode(self, du):
        lay = self.lay
        for t in range(T):
            for i, adr in lay.ctrl:
                self.ctrl[:, i] = 0.0 if adr < 0 else self.qpos[:, adr] + 0.0
            for mocap, body in lay.welds:
                self.mocap_pos[:, mocap] = self.xpos[:, body]
                self.mocap_quat[:, mocap] = self.xquat[:, body]
            self.mocap_pos[:] = self.mocap_pos + du[t][:, None, :]
            self.mocap_quat[:] = self.mocap_quat + ROT
            self.b.step(nstep=SUB)
            self.qpos[:, lay.fingers] = 0.0
            self.b.forward()

    def states(self):
        return list(np.array(self.state))


def main() -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--rounds", type=int, default=10)
    p.add_argument("--dump", help="write the 4 start states (named fields) here")
    p.add_argument("--states", help="start states from --dump (no real envs needed)")
    a = p.parse_args()
    envs, why = (None, "--states given") if a.states else real_envs()
    if envs is not None:
        m = envs[0].model
        start = {f: np.stack([getattr(e.data, f).copy() for e in envs]) for f in FIELDS}
        if a.dump:
            np.savez(a.dump, **start)
    else:
        if not a.states:
            print(f"no env ({why}) and no --states", file=sys.stderr)
            return 2
        m = push_model()
        with np.load(a.states) as z:
            start = {f: z[f] for f in FIELDS}
    lay = Layout(m)
    print(
        f"mujoco {mujoco.__version__}, mjbatch {importlib.metadata.version('mjbatch')} "
        f"({os.path.dirname(mjbatch.__file__)}), real envs: "
        f"{'yes' if envs is not None else 'no, ' + why}",
        flush=True,
    )
    # the start states as mjSTATE_INTEGRATION vectors of this mujoco
    d0 = mujoco.MjData(m)
    states0 = []
    for i in range(N):
        mujoco.mj_resetData(m, d0)
        for f in FIELDS:
            getattr(d0, f)[:] = start[f][i]
        mujoco.mj_forward(m, d0)
        states0.append(get_state(m, d0))

    if envs is not None:  # the replica is the env's physics: same qpos, qvel
        from acder_lite.envs import fetch as E

        rng = np.random.default_rng(123)
        acts = rng.uniform(-1, 1, (T, N, 4)).astype(np.float32)
        acts[..., 3] = 0  # the gripper's ctrl is 0 on Push whatever the action
        ref = Plain(m, lay)
        ref.load(states0)
        du = (acts[..., :3] * np.float32(0.05)).astype(np.float64)
        ref.episode(du)
        for t in range(T):
            for i, env in enumerate(envs):
                E.step(env, acts[t, i])
        same = all(
            np.array_equal(env.data.qpos, d.qpos)
            and np.array_equal(env.data.qvel, d.qvel)
            for env, d in zip(envs, ref.data)
        )
        print(
            "replica against envs.step, 50 steps of 4 envs: "
            + ("same" if same else "DIFF")
        )
        # the model --states runs on (push_model) against the env's own
        mine = Plain(push_model(), lay)
        mine.load(states0)
        mine.episode(du)
        same = all(np.array_equal(x, y) for x, y in zip(mine.states(), ref.states()))
        print("push_model() against the env's model: " + ("same" if same else "DIFF"))

    pool = StepPool(THREADS)
    ways = {
        "sequential": Plain(m, lay),
        "step_pool": Plain(m, lay, pool),
        "mjbatch-1": Batched(m, lay, 1),
        "mjbatch-2": Batched(m, lay, THREADS),
        "unsynced": Unsynced(m, lay, pool),
    }
    wall = {k: [] for k in ways}
    cpu = {k: [] for k in ways}
    diff = {k: 0 for k in ways}
    for r in range(a.rounds):
        du = deltas(np.random.default_rng(r))
        final = {}
        for k, way in ways.items():
            way.load(states0)
            w, c = time.perf_counter(), time.process_time()
            way.episode(du)
            wall[k].append((time.perf_counter() - w) * 1e3)
            cpu[k].append((time.process_time() - c) * 1e3)
            final[k] = way.states()
        for k in ways:
            same = all(
                np.array_equal(x, y) for x, y in zip(final[k], final["sequential"])
            )
            diff[k] += not same
        nq = m.nq
        err = max(
            float(np.abs(x[1 : 1 + nq] - y[1 : 1 + nq]).max())
            for x, y in zip(final["mjbatch-2"], final["sequential"])
        )
        print(
            f"round {r}: wall ms "
            + " ".join(f"{k}={wall[k][-1]:.1f}" for k in ways)
            + f"; mjbatch-2's max |qpos - sequential's| {err:.1e}",
            flush=True,
        )
    pool.shutdown()
    base_w, base_c = st.median(wall["sequential"]), st.median(cpu["sequential"])
    for k in ways:  # the medians
        mw, mc = st.median(wall[k]), st.median(cpu[k])
        print(
            f"{k:10s} ms per episode of 4 envs: wall median {mw:6.1f} "
            f"({mw / base_w:.2f} of sequential), CPU median {mc:6.1f} "
            f"({mc / base_c:.2f}); final states equal to sequential's in "
            f"{a.rounds - diff[k]} of {a.rounds} rounds"
        )
    return 0


if __name__ == "__main__":
    sys.exit(main())
