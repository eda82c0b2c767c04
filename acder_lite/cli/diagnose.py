"""Diagnose a run: S-ICM's novelty, the start pool, how the policy moves the object

`python -m acder_lite diagnose results/FetchPush-v4/acder/seed4` loads the run's
`checkpoint.pt` (a run folder that still holds one: not a copied `same_as` cell, and
only on the machine that trained it, the file being too large to commit) or, without
one, its packed checkpoint (`checkpoint.packed/`, which a run in flight carries in git
from session to session: its buffer is re-simulated first, minutes), draws
minibatches from its replay buffer exactly as training does, and reports

- **curiosity**: how the S-ICM error 1/2 ||F(s, a) - s'||^2 (Eq. 4 before the clip) is
  spread, the share of rows at the clip eta, overall and among rows of successful
  episodes (the rows the start-state selection chooses from), and which state entries
  carry the error;
- **pool**: where the stored start states put the gripper and the object;
- **motion** (tasks with an object; needs only the committed `policy.pt`): how the
  trained policy moves the object on test episodes: its speed, its spin, its path
  against the straight line, and how often one of its Euler angles wraps around
  (`angle_wraps`), a jump of the observation that Eq. 4 rewards at its clip.

On the multi-step push (FetchPushMultiStep-v0: two blocks, 6-D goals) the state names
are the 40 observation entries (object0_..., object1_...) and goal0.x ... goal1.z; the
pool reports each block (the gripper's distance to it, its distance to its own target)
and the motion is per block. The one-object tasks report exactly the numbers they always
did.

`minibatch_errors` takes S-ICM's error on training minibatches (chapter 6); its error
on whole episodes, chapter 4's familiar against unseen transitions, is `novelty`'s.

Nothing is trained and nothing in the run folder is written, except the `--json` file if
asked. Two traps it exists to show: when many rows sit at the clip, "the largest
intrinsic reward" is a tie and the candidate is in effect any clipped row of a
successful episode; and a candidate is a state *inside* a successful episode, not its
end, so the gripper may be anywhere.
"""

from __future__ import annotations

import argparse
import math
import os
import sys

import numpy as np
import torch

from acder_lite.envs import fetch as E
from acder_lite.runs import packed
from acder_lite.config import OBJECT_ENVS, Config, ConfigError
from acder_lite.algo.curiosity import SICM
from acder_lite.io import (
    CheckpointError,
    check_output,
    json_ready,
    load_torch,
    write_error,
    write_json,
)
from acder_lite.envs.observations import rotation_indices, sincos_names
from acder_lite.algo.rewards import intrinsic_reward
from acder_lite.algo.start_states import select_candidate
from acder_lite.words import count
from acder_lite.runs.wraps import GIMBAL_COS, angle_wraps, near_gimbal_lock


MAX_BATCHES = 10_000
"""The most minibatches `--batches` draws: 10^7 rows at the protocol's 1024 a
minibatch, 2.5 times the 4 x 10^6 transitions a full buffer holds; the error's quantiles
have settled long before. Trap: a huge --batches ran for ever."""
MAX_EPISODES = 10_000
"""The most test episodes `--episodes` rolls out: a thousand times eval's default 10
(about 20 minutes here, at 0.12 s a Push episode). Trap: a huge --episodes ran for
ever."""
BATCHES = 10
"""The minibatches drawn without --batches."""


def state_names(trainer) -> list[str]:
    """Names of the S-ICM state s = (o, g): the observation entries, then the goal's
    (goal.x/y/z, or goal0.x ... goal1.z for the two blocks' targets of
    FetchPushMultiStep-v0). With `Config.sicm_angles="sincos"` the observation's
    Euler angles are "sin ..." and "cos ..." entries after the others
    (`observations.sincos_names`), as S-ICM sees them."""
    env = trainer.envs[0]
    names, size = E.obs_names(env), trainer.dims["o"] + trainer.dims["g"]
    if trainer.sicm_angles is not None:  # one entry more per angle
        names = sincos_names(names, trainer.sicm_angles)
        size += trainer.sicm_angles.size
    names = names + E.goal_names(env)
    if len(names) != size:  # a changed layout must not be mislabelled silently
        raise RuntimeError(
            f"state_names: {len(names)} names for a state of {size} entries"
        )
    return names


def n_objects(env) -> int:
    """Objects on the table: 0 (Reach), 1 (Push, Pick&Place, Slide), 2
    (FetchPushMultiStep-v0)."""
    return int(getattr(env, "n_objects", 1)) if env.has_object else 0


def _rot_fields(env) -> list[slice]:
    """The blocks' Euler-angle slices of the observation; none without a block, or on
    a simplified state (which drops the angles)."""
    if not len(rotation_indices(E.obs_names(env))):
        return []
    return object_fields(env, "rot")


def object_fields(env, field: str) -> list[slice]:
    """One slice of the observation per object for an object field (`pos`, `velr`, ...),
    by name: object_velr.x..z on the one-object tasks, object0_velr.x..z,
    object1_velr.x..z on the multi-step push (`envs.obs_names`)."""
    names = E.obs_names(env)
    k = n_objects(env)
    prefixes = ["object"] if k == 1 else [f"object{i}" for i in range(k)]
    return [
        slice(names.index(f"{p}_{field}.x"), names.index(f"{p}_{field}.z") + 1)
        for p in prefixes
    ]


def curiosity_profile(trainer, batches: int = 10, top: int = 5) -> dict:
    """S-ICM's prediction errors on `batches` training minibatches,
    without updating the model.

    Returns the share of rows whose error reaches eta (so Eq. 4 clips them), the same
    share among rows of successful episodes, error quantiles, and the `top` state
    entries by mean squared error. Where the state holds the blocks' Euler angles
    (`object_rot`), also `wraps`: the share of rows whose step turns a block through an
    angle's wrap (`wraps.angle_wraps`), that share among the rows at the clip, and among
    the start-state candidates the minibatches give (`start_states.select_candidate`,
    one a minibatch, as training offers them); and `gimbal`, the same three shares for
    the rows whose block is near gimbal lock (`wraps.near_gimbal_lock`).
    """
    if not isinstance(trainer.curiosity, SICM):
        raise ConfigError(
            f"method={trainer.cfg.method!r} has no S-ICM to diagnose; allowed: acder "
            "and its ablations"
        )
    eta = trainer.cfg.eta
    rot = _rot_fields(trainer.envs[0])
    errs, succ, sq = [], [], 0.0
    wrap, lock, picked = [], [], []  # per row; `picked`: (wrap, lock) of a candidate
    with torch.no_grad():
        for _ in range(batches):
            b = trainer.sample_batch()
            tb = trainer.batch_tensors(b)
            x, x2 = trainer.curiosity_inputs(b, tb)
            err, pred = trainer.curiosity.errors(x, tb["u"], x2)
            errs.append(err.numpy())
            succ.append(trainer.buffer.success[b["ep"]])
            sq = sq + (pred - x2).pow(2).mean(0).numpy() / batches
            if rot:
                w, k = np.zeros(len(b["o"]), bool), np.zeros(len(b["o"]), bool)
                for f in rot:  # (B, 2, 3): the angles before and after the step
                    pair = np.stack([b["o"][:, f], b["o2"][:, f]], 1)
                    w |= angle_wraps(pair)[:, 0]
                    k |= near_gimbal_lock(pair)[:, 0]
                wrap.append(w)
                lock.append(k)
                # Eq. 4 as the trainer takes it, so the candidate is the one it offers
                r_int = intrinsic_reward(
                    pred.cpu().numpy(), x2.cpu().numpy(), eta
                ).astype(np.float32)
                row = select_candidate(r_int, succ[-1].astype(bool))
                if row is not None:
                    picked.append((bool(w[row]), bool(k[row])))
    err, succ = np.concatenate(errs), np.concatenate(succ)
    names = state_names(trainer)
    order = np.argsort(-sq)[:top]
    extra = {}
    if rot:
        clipped = err >= eta
        for key, rows, i in (("wraps", wrap, 0), ("gimbal", lock, 1)):
            m = np.concatenate(rows)
            extra[key] = dict(
                share_of_rows=float(m.mean()),
                share_at_clip=float(m[clipped].mean()) if clipped.any() else math.nan,
                candidates=len(picked),
                share_of_candidates=(
                    float(np.mean([p[i] for p in picked])) if picked else math.nan
                ),
            )
        extra["gimbal"]["cos_below"] = GIMBAL_COS
    return (
        dict(
            eta=eta,
            sicm_angles=trainer.cfg.sicm_angles,  # how S-ICM saw the angles
            rows=int(err.size),
            successful_rows=int(succ.sum()),
            share_at_clip=float((err >= eta).mean()),
            share_at_clip_successful=float((err[succ] >= eta).mean())
            if succ.any()
            else float("nan"),
            error_quantiles={
                str(q): float(v)
                for q, v in zip(
                    (0.1, 0.5, 0.9, 0.99), np.quantile(err, [0.1, 0.5, 0.9, 0.99])
                )
            },
            top_entries=[(names[i], float(sq[i])) for i in order],
            share_of_error_in_top=float(sq[order].sum() / max(sq.sum(), 1e-12)),
        )
        | extra
    )


def minibatch_errors(trainer, batches: int = 10) -> dict:
    """S-ICM's error 1/2 ||F(s, a) - s'||^2 (Eq. 4 before the clip) on `batches`
    minibatches drawn as training draws them, on the inputs the trainer gives the model;
    nothing is trained.

    Returns `err` (one number per row), `successful` (whether the row's episode ended in
    success: the rows the start-state selection chooses from,
    `start_states.select_candidate`) and `eta`. Eq. 4 of a row is `min(err, eta)`, so
    every successful row with err >= eta ties for the candidate."""
    if not isinstance(trainer.curiosity, SICM):
        raise ConfigError(
            f"method={trainer.cfg.method!r} has no S-ICM; "
            "allowed: acder and its ablations"
        )
    errs, succ = [], []
    with torch.no_grad():
        for _ in range(batches):
            b = trainer.sample_batch()
            tb = trainer.batch_tensors(b)
            x, x2 = trainer.curiosity_inputs(b, tb)
            errs.append(trainer.curiosity.errors(x, tb["u"], x2)[0].cpu().numpy())
            succ.append(trainer.buffer.success[b["ep"]])
    err = np.concatenate(errs).astype(np.float64)
    ok = np.concatenate(succ).astype(bool)
    return dict(err=err, successful=ok, eta=float(trainer.cfg.eta))


def goal_factor_against_object(
    grip: np.ndarray,
    obj: np.ndarray,
    goal: np.ndarray,
    action: np.ndarray,
    moved: float = 0.01,
) -> dict:
    """What Eq. 6 rewards on a one-object task, against the way to the block
    (chapter 5).

    Rows of relabelled transitions: `grip` the gripper position s^a_t, `obj` the block's
    position at step t, `goal` the relabelled 3-D goal g^h (a later block position),
    `action` the action a_t; shapes (B, 3) (the action (B, 4)). Returns, per row,

    - `lam_goal`: Eq. 6 as the trainer computes it (`rewards.goal_oriented_factor`,
      gripper -> g^h);
    - `lam_obj`: Eq. 6 of the same action against the block (gripper -> block);
    - `angle`: the angle between gripper -> g^h and gripper -> block, in degrees;
    - `moved`: whether the block moved between step t and g^h's step (g^h more than
      `moved`, 1 cm, from the block).

    The angle is Eq. 6 read backwards, (lambda - 1) * 360 degrees, with the direction
    to the block in the place of the action: 0 when g^h and the block lie in the same
    direction from the gripper, 90 when either vector is shorter than
    `rewards.ZERO_NORM`."""
    from acder_lite.algo.rewards import goal_oriented_factor

    grip, obj, goal = (np.asarray(a, np.float64) for a in (grip, obj, goal))
    to_obj = obj - grip
    return dict(
        lam_goal=goal_oriented_factor(grip, goal, action),
        lam_obj=goal_oriented_factor(grip, obj, action),
        angle=360.0 * (goal_oriented_factor(grip, goal, to_obj) - 1.0),
        moved=np.linalg.norm(goal - obj, axis=-1) > moved,
    )


def pool_positions(trainer, env=None) -> dict:
    """The stored start states of the trainer's pool, and what they put where.

    Returns `states` (n, state size), `goals` (n, goal size) and `r_int` (n,), as the
    pool keeps them (oldest first), with `gripper` (n, 3), the gripper position each
    state puts the arm at, `observation` (n, obs size), the env's observation there,
    and `distinct`, the number of different states (the same row of a successful
    episode can be offered again by a later minibatch). `env`: an env of the trainer's
    task to set the states in (by default a new one); its own state is put back."""
    if trainer.selector is None:
        raise ConfigError(
            f"method={trainer.cfg.method!r} has no start-state pool; allowed: acder, "
            "acder-no-curiosity, acder-no-goal-factor"
        )
    pool = list(trainer.selector.pool)
    env = E.make_env(trainer.cfg.env, seed=0) if env is None else env
    n_state, n_goal = E.state_size(env), trainer.dims["g"]
    n_obs = E.observe(env)["observation"].size
    obs = []
    saved = E.get_state(env)
    for c in pool:
        if c["state"].size != n_state:
            raise CheckpointError(
                f"the pool's states have {c['state'].size} numbers, not "
                f"envs.STATE_SPEC's {n_state}; allowed: a checkpoint written "
                "by this version"
            )
        E.set_state(env, c["state"])
        obs.append(np.array(E.observe(env)["observation"], np.float64))
    E.set_state(env, saved)
    states = np.stack([c["state"] for c in pool]) if pool else np.zeros((0, n_state))
    obs = np.array(obs).reshape(len(pool), n_obs)
    return dict(
        states=states,
        goals=np.array([c["goal"] for c in pool], np.float64).reshape(-1, n_goal),
        r_int=np.array([c["r_int"] for c in pool], np.float64),
        observation=obs,
        gripper=obs[:, :3],
        distinct=int(len(np.unique(states, axis=0))) if pool else 0,
    )


def pool_profile(trainer, far: float = 0.2) -> dict:
    """Where the pool's start states put the gripper (and the object,
    on tasks that have one).

    `far` (metres): a candidate whose gripper is farther than this from the object (or,
    on Reach, from the candidate's goal) counts as far. With several objects (the
    multi-step push) the distance is to the nearest block, and `blocks` gives, per
    block, the gripper's distance to it and the block's distance to its own target (the
    candidate's goal), with the share of candidates where the block is on its target
    (within the env's distance_threshold). The states are read by `pool_positions`.
    """
    env = E.make_env(trainer.cfg.env, seed=0)
    P = pool_positions(trainer, env)
    k = n_objects(env)
    pos = object_fields(env, "pos") if k > 1 else None
    obs, r_int, n = P["observation"], P["r_int"], len(P["r_int"])
    grip = P["gripper"]
    other = obs[:, 3:6] if env.has_object else P["goals"]
    if pos is not None:
        blocks = np.stack([obs[:, s] for s in pos], 1)  # (n, k, 3)
        goals = P["goals"].reshape(n, k, 3)
    eta = trainer.cfg.eta
    out = dict(size=n, far=far, eta=eta)
    if not n:
        return out
    d = np.linalg.norm(grip - other, axis=1)
    if pos is not None:
        to_block = np.linalg.norm(blocks - grip[:, None], axis=-1)  # (n, k)
        to_target = np.linalg.norm(blocks - goals, axis=-1)
        d = to_block.min(axis=1)
    out.update(
        # r_int is S-ICM's min(err, eta) in float32: an eta that float32 rounds down
        # (0.7) is stored below the float64 eta, so compare with the lower of the two
        share_at_clip=float((r_int >= min(eta, float(np.float32(eta)))).mean()),
        distance_to=("object" if k == 1 else "nearest block" if k else "goal"),
        distance_median=float(np.median(d)),
        distance_max=float(d.max()),
        share_far=float((d > far).mean()),
        gripper_z_min=float(grip[:, 2].min()),
        gripper_z_median=float(np.median(grip[:, 2])),
    )
    if pos is not None:
        out["blocks"] = [
            dict(
                distance_median=float(np.median(to_block[:, i])),
                distance_max=float(to_block[:, i].max()),
                share_far=float((to_block[:, i] > far).mean()),
                to_target_median=float(np.median(to_target[:, i])),
                share_on_target=float(
                    (to_target[:, i] < env.distance_threshold).mean()
                ),
            )
            for i in range(k)
        ]
    return out


def motion_stats(
    ag: np.ndarray, velr: np.ndarray, dt: float, rot: np.ndarray | None = None
) -> dict:
    """Speed, spin and path of one object: `ag` its positions (N, T+1, 3), `velr` the
    observation's object_velr of it (N, T, 3, steps 1..T), `rot` its object_rot
    (N, T+1, 3; `angle_wraps`)."""
    steps = np.linalg.norm(np.diff(ag, axis=1), axis=-1)  # (N, T)
    speed = steps / dt
    spin = np.linalg.norm(velr, axis=-1) / dt
    path = steps.sum(1)
    disp = np.linalg.norm(ag[:, -1] - ag[:, 0], axis=-1)
    moved = (
        disp > 0.02
    )  # episodes where the object ended more than 2 cm from where it began
    return dict(
        speed_mean=float(speed.mean()),
        spin_mean=float(spin.mean()),
        spin_p99=float(np.quantile(spin, 0.99)),
        path_mean=float(path.mean()),
        moved_share=float(moved.mean()),
        path_over_distance=float(np.median(path[moved] / disp[moved]))
        if moved.any()
        else float("nan"),
    ) | ({} if rot is None else _wrap_shares(angle_wraps(rot)))


def _wrap_shares(wraps: np.ndarray) -> dict:
    """Shares of steps and of episodes with a wrap, from `angle_wraps`' (N, T)."""
    return dict(
        wrap_step_share=float(wraps.mean()),
        wrap_episode_share=float(wraps.any(-1).mean()),
    )


def object_motion(
    policy, env_id: str, episodes: int = 40, seed: int = 12345, workers: int = 4
) -> dict:
    """How a policy moves the object on deterministic test episodes
    (tasks with an object).

    Per step: the object's speed (m/s, from its position, the achieved goal) and spin
    (rad/s, the observation's `object_velr`, which Fetch scales by dt). Per episode: the
    object's path length over the distance from its first to its last position (1 = a
    straight push; large = pushed around). `episodes` is rounded up to a multiple of
    `workers` (envs stepped together).

    With several objects (the multi-step push) every number is per block, under `blocks`
    (block 0 first; its achieved-goal columns [3k, 3k+3) and its own object{k}_velr
    entries), beside the episodes' success (both blocks on their targets).
    """
    from acder_lite.train.rollout import run_episodes

    envs = [E.make_env(env_id, seed=seed + i) for i in range(workers)]
    if not envs[0].has_object:
        raise ConfigError(
            f"env={env_id!r} has no object to follow; allowed: {', '.join(OBJECT_ENVS)}"
        )
    velr, rot = object_fields(envs[0], "velr"), object_fields(envs[0], "rot")
    dt, T = float(envs[0].dt), E.horizon(env_id)
    ags, spins, rots, succ = [], [], [], []
    for _ in range(-(-episodes // workers)):
        ep = run_episodes(envs, policy, T)
        ags.append(ep["ag"].astype(np.float64))
        spins.append(
            np.stack([ep["o"][:, 1:, s].astype(np.float64) for s in velr])
        )  # (k, W, T, 3)
        rots.append(np.stack([ep["o"][:, :, s] for s in rot]))  # (k, W, T+1, 3)
        succ.append(ep["success"])
    ag, spin, rots, succ = (
        np.concatenate(ags),
        np.concatenate(spins, axis=1),
        np.concatenate(rots, axis=1),
        np.concatenate(succ),
    )
    stats = [
        motion_stats(ag[..., 3 * i : 3 * i + 3], spin[i], dt, rots[i])
        for i in range(len(velr))
    ]
    out = dict(episodes=int(succ.size), success=float(succ.mean()))
    if len(stats) == 1:
        out.update(stats[0])
    else:
        out["blocks"] = stats
    return out


def diagnose(
    run_dir: str, batches: int = 10, episodes: int = 0, seed: int = 12345, top: int = 5
) -> dict:
    """Curiosity and pool profiles of the run in `run_dir`, from its checkpoint.pt (the
    `top` state entries by S-ICM error); or, with `episodes` > 0, the object's motion
    under its policy.pt (which committed runs keep)."""
    from acder_lite.train.rollout import Policy
    from acder_lite.train.trainer import Trainer

    if not os.path.isdir(run_dir):
        what = "is a file" if os.path.exists(run_dir) else "does not exist"
        raise CheckpointError(
            f"run folder {run_dir!r} {what}; allowed: a folder written by "
            "train (its checkpoint.pt, or policy.pt with --episodes)"
        )
    if episodes > 0:
        path = os.path.join(run_dir, "policy.pt")
        # runs nothing from the file; checks keys and shapes
        pol = load_torch(path)["policy"]
        if pol["env"] not in E.ENV_IDS:
            raise CheckpointError(
                f"checkpoint {path!r} names env {pol['env']!r}; allowed: one of "
                f"{', '.join(E.ENV_IDS)}"
            )
        policy = Policy.from_state_dict(pol)
        from acder_lite.envs.fetch import policy_env
        from acder_lite.envs.observations import on_full

        env = policy_env(pol, path)
        env.close()
        # the motion reads the full observation (object_velr); a simplified-state policy
        # is shown its own entries of it
        act = (
            policy
            if getattr(env, "obs_index", None) is None
            else on_full(policy, env.obs_index)
        )
        return dict(
            run=run_dir,
            method=pol["method"],
            env=pol["env"],
            motion=object_motion(act, pol["env"], episodes, seed),
        )
    path = os.path.join(run_dir, "checkpoint.pt")
    if not os.path.exists(path) and packed.has_packed(run_dir):
        # a run carried over in git (`pack`): its buffer is re-simulated, minutes
        path = os.path.join(run_dir, packed.FOLDER)
        files = packed.read(run_dir)  # a damaged file: its one line, said first
        print(f"diagnose: rebuilding the replay buffer from {path}", file=sys.stderr)
        ckpt = packed.unpack(run_dir, files=files)
    elif not os.path.exists(path) and os.path.isfile(
        os.path.join(run_dir, "policy.pt")
    ):
        raise CheckpointError(
            f"run folder {run_dir!r} has policy.pt but no checkpoint.pt: a finished "
            "run keeps only its policy (no replay buffer), and the minibatch diagnosis "
            "needs checkpoint.pt (or a packed run, checkpoint.packed/); allowed: "
            "--episodes N to diagnose the policy on N fresh episodes"
        )
    else:
        ckpt = load_torch(path)
    if "buffer" not in ckpt:
        raise CheckpointError(
            f"checkpoint {path!r} holds a policy only; allowed: a checkpoint.pt "
            "written by train"
        )
    try:
        cfg = Config.from_dict(ckpt["config"])
    except ConfigError as e:
        raise CheckpointError(
            f"checkpoint {path!r} holds a config this version cannot use: {e}"
        ) from None
    if not (cfg.switches["curiosity"] == "sicm" or cfg.switches["start_states"]):
        raise ConfigError(
            f"method={cfg.method!r} has neither S-ICM nor a start-state pool; allowed: "
            "acder and its ablations, or --episodes N for the object's motion"
        )
    cfg.threads = 1
    tr = Trainer(cfg)
    try:
        tr.load_state_dict(ckpt)
    except CheckpointError as e:
        raise CheckpointError(f"checkpoint {path!r}: {e}") from None
    except (
        KeyError,
        IndexError,
        TypeError,
        ValueError,
        RuntimeError,
        AttributeError,
    ) as e:
        # a part of the file does not fit the networks and buffers its own config builds
        msg = str(e).strip().splitlines()[0] if str(e).strip() else ""
        raise CheckpointError(
            f"checkpoint {path!r} does not fit its own config ({type(e).__name__}: "
            f"{msg[:160]}); allowed: a checkpoint.pt written by train"
        ) from None
    out = dict(
        run=run_dir,
        method=cfg.method,
        env=cfg.env,
        episodes=tr.episodes,
        test_success=tr.success_rate,
    )
    if isinstance(tr.curiosity, SICM):
        out["curiosity"] = curiosity_profile(tr, batches, top)
    if tr.selector is not None:
        out["pool"] = pool_profile(tr)
    return out


def to_text(d: dict) -> str:
    lines = [
        f"{d['run']}: {d['method']} on {d['env']}"
        + (
            f", {count(d['episodes'], 'episode')}, test success {d['test_success']:.3f}"
            if "episodes" in d
            else ""
        )
    ]
    c = d.get("curiosity")
    if c:
        q = c["error_quantiles"]
        lines += [
            f"curiosity: {count(c['rows'], 'row')}; error median {q['0.5']:.3g}, 90% "
            f"{q['0.9']:.3g}, 99% {q['0.99']:.3g}; at the clip eta={c['eta']}: "
            f"{c['share_at_clip']:.2f} of all rows, "
            + (
                f"{c['share_at_clip_successful']:.2f} of the "
                f"{count(c['successful_rows'], 'row')} of successful episodes"
                if c["successful_rows"]
                else "no row of a successful episode drawn"
            ),
            f"  largest errors ({c['share_of_error_in_top']:.0%} of the total): "
            + ", ".join(f"{n} {v:.3g}" for n, v in c["top_entries"]),
        ]
        for key, what in (
            ("wraps", "Euler-angle wraps"),
            ("gimbal", f"near gimbal lock (|cos pitch| < {GIMBAL_COS})"),
        ):
            w = c.get(key)
            if not w:
                continue
            at_clip = (
                f"{w['share_at_clip']:.2f} of the rows at the clip"
                if w["share_at_clip"] == w["share_at_clip"]  # nan: no row at the clip
                else "no row at the clip"
            )
            picked = (
                f"{w['share_of_candidates']:.2f} of the {w['candidates']} start-state "
                f"{'candidate' if w['candidates'] == 1 else 'candidates'} the "
                "minibatches give"
                if w["candidates"]
                else "no start-state candidate in the drawn minibatches (none of "
                "their rows is of a successful episode)"
            )
            lines.append(
                f"  {what}: {w['share_of_rows']:.4f} of all rows, {at_clip}, {picked}"
            )
    p = d.get("pool")
    if p:
        if p["size"] == 0:
            lines.append("pool: empty")
        else:
            lines.append(
                f"pool: {count(p['size'], 'candidate')}, {p['share_at_clip']:.2f} at "
                "the clip; "
                f"gripper to {p['distance_to']}: median {p['distance_median']:.3f} m, "
                f"max {p['distance_max']:.3f} m, {p['share_far']:.2f} farther than "
                f"{p['far']} m; gripper height min {p['gripper_z_min']:.3f} m, median "
                f"{p['gripper_z_median']:.3f} m"
            )
            for i, b in enumerate(p.get("blocks", [])):
                lines.append(
                    f"  block {i}: gripper to it median {b['distance_median']:.3f} m, "
                    f"max {b['distance_max']:.3f} m, {b['share_far']:.2f} farther than "
                    f"{p['far']} m; to its target median {b['to_target_median']:.3f} "
                    f"m, on it in {b['share_on_target']:.2f} of the candidates"
                )
    m = d.get("motion")
    if m:
        head = (
            f"motion: {count(m['episodes'], 'test episode')}, "
            f"success {m['success']:.3f}"
        )
        if "blocks" not in m:
            lines.append(f"{head}; object {_motion_text(m)}")
        else:
            lines.append(head)
            lines += [
                f"  block {i}: {_motion_text(b)}" for i, b in enumerate(m["blocks"])
            ]
    return "\n".join(lines)


def _motion_text(m: dict) -> str:
    path = (
        f", path {m['path_over_distance']:.2f} x the distance (median)"
        if m["moved_share"] > 0
        else ""  # no episode moved it: no path to measure (path_over_distance is nan)
    )
    wraps = (
        f"; an Euler angle wraps at {m['wrap_step_share']:.4f} of the steps, in "
        f"{m['wrap_episode_share']:.2f} of the episodes"
        if "wrap_step_share" in m
        else ""
    )
    return (
        f"speed {m['speed_mean']:.4f} m/s, spin {m['spin_mean']:.3f} rad/s (99%: "
        f"{m['spin_p99']:.2f}); moved in {m['moved_share']:.2f} of the episodes{path}"
        f"{wraps}"
    )


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument(
        "run",
        help="a run folder holding checkpoint.pt, or checkpoint.packed/ (`pack`), "
        "whose replay buffer is then re-simulated first (minutes)",
    )
    parser.add_argument(
        "--batches",
        type=int,
        default=None,
        help=f"minibatches to draw, at most {MAX_BATCHES} (default: {BATCHES}; not "
        "with --episodes)",
    )
    parser.add_argument(
        "--episodes",
        type=int,
        default=None,
        metavar="N",
        help="instead, roll out the run's policy.pt for N test episodes and report how "
        "it moves the object (tasks with an object; needs no checkpoint). The 4 test "
        f"envs step together, so N is rounded up to a multiple of 4; at most "
        f"{MAX_EPISODES}",
    )
    parser.add_argument(
        "--seed", type=int, default=12345, help="seed of the test envs for --episodes"
    )
    parser.add_argument(
        "--top",
        type=int,
        default=5,
        help="state entries to name by S-ICM error (default: 5)",
    )
    parser.add_argument(
        "--json",
        metavar="FILE",
        help="also write the numbers to FILE (replaced if it exists)",
    )


def run(args) -> int:
    if args.batches is not None and args.episodes is not None:
        # --batches was ignored without a word: the episodes draw no minibatch
        raise ConfigError(
            f"--batches {args.batches} and --episodes {args.episodes} exclude each "
            "other; allowed: --batches N (minibatches of checkpoint.pt) or --episodes "
            "N (episodes of policy.pt)"
        )
    batches = BATCHES if args.batches is None else args.batches
    if not 1 <= batches <= MAX_BATCHES:
        raise ConfigError(
            f"batches={batches} is not allowed: an integer in [1, {MAX_BATCHES}]"
        )
    if args.episodes is not None and args.episodes < 1:
        # 0 used to fall back on the minibatch diagnosis without a word
        raise ConfigError(
            f"episodes={args.episodes} is not allowed: an integer >= 1 (omit "
            "--episodes for the minibatch diagnosis)"
        )
    if args.episodes is not None and args.episodes > MAX_EPISODES:
        raise ConfigError(
            f"episodes={args.episodes} is not allowed: an integer in "
            f"[1, {MAX_EPISODES}]"
        )
    if args.top < 1:
        raise ConfigError(f"top={args.top} is not allowed: an integer >= 1")
    if args.seed is not None and args.seed < 0:
        raise ConfigError(f"seed={args.seed} is not allowed: an integer >= 0")
    if args.json is not None:  # before the work, not after it
        check_output(args.json, "json")
    d = diagnose(args.run, batches, args.episodes or 0, args.seed, args.top)
    print(to_text(d))
    if args.json:
        try:
            write_json(args.json, json_ready(d))  # a share of no rows: null, not NaN
        except OSError as e:
            raise write_error("json", args.json, e) from None
    return 0
