"""Videos of a policy for readers without WebGL: one episode rendered offline by
MuJoCo's own renderer (`mujoco.Renderer`) and written as an animated GIF (or WebP), an
image every browser plays without plugins or a network.

**What is rendered.** `render_episode` rolls out one episode with the trainer's own
`run_episodes` (the deterministic policy of a run folder or policy file,
`io.load_policy`, in the env it was trained on, `envs.policy_env`; or uniformly random
actions), stores the full MuJoCo state of every step, then draws the states one by one,
so drawing never touches the rollout. Each frame is what the Fetch tasks' own render
shows: gymnasium-robotics' camera for Fetch (`fetch_camera`: distance 2.5 m, azimuth
132 deg, elevation -14 deg, looking at (1.3, 0.75, 0.55)), with the env's
`_render_callback` moving the target site (`target0`; `target1` too on the multi-step
push) to the goal. Three departures from that render, for a small frame: the mocap
target's helper boxes (the faint green cross through the scene) are hidden, as in the
Meshcat scenes of `viz`; each target gets a translucent ball of the success radius
(5 cm: the block, or on FetchReach the gripper, must end inside it) in the target's
colour; and the target is drawn through whatever hides it (`XRAY`: from this camera
the gripper often stands in front of FetchReach's target, the block on Push's).

**Headless GL.** MuJoCo picks its OpenGL backend once, when `mujoco` is first imported,
from `MUJOCO_GL`. Importing this module sets `MUJOCO_GL=egl` when the variable is
unset, MuJoCo is not imported yet (so import this module first in a notebook) and
libEGL is installed: Mesa's EGL renders on the CPU (llvmpipe) without a display. On
Debian: `apt-get install libegl1 libegl-mesa0 libgl1-mesa-dri libopengl0` (`.ci/run`
does). `MUJOCO_GL=osmesa` (libosmesa6) is the other headless choice. `gl_problem` says
in one line why rendering cannot work, if it cannot.

**Files.** `write_video` writes GIF (one global palette, no dithering: flat colours
compress well) or animated WebP (lossy), by the file's suffix. One episode of 50 steps
at 320x240 is a few hundred kB. `python -m acder_lite.book.video RUN OUT.gif` renders
one (experiments/videos/make.sh renders the book's).
"""

from __future__ import annotations

import argparse
import os
import sys
from dataclasses import dataclass

import numpy as np


def _egl_installed() -> bool:
    """Whether libEGL and a GL library are on the loader's path: without them
    `MUJOCO_GL=egl` makes `import mujoco` itself fail, not just rendering."""
    from ctypes.util import find_library

    return bool(find_library("EGL") and (find_library("OpenGL") or find_library("GL")))


# MuJoCo reads MUJOCO_GL once, when first imported
if "mujoco" not in sys.modules and "MUJOCO_GL" not in os.environ and _egl_installed():
    os.environ["MUJOCO_GL"] = "egl"

TOLERANCE = 0.05
"""The Fetch tasks' success radius (`distance_threshold`, metres): the size of the
translucent ball drawn around each target."""

XRAY = 0.6
"""Opacity of a target drawn over whatever hides it (the arm, the block), so the goal
stays visible: each frame is rendered a second time with only the sites, and the
target's pixels there are blended into the frame in the target's colour."""

FIRST_TEST_SEED = 500
"""The env seed of a seed-0 run's first test env (`envs.run_env_seeds(0, W,
test=True)[0]`): the default episode of a video."""


def _mujoco():
    """`mujoco` (imported on first use: its GL backend is the one `MUJOCO_GL` names
    then; this module's import set egl if MuJoCo was not imported yet)."""
    import mujoco

    return mujoco


def gl_problem() -> str | None:
    """None if MuJoCo can render offscreen here, else one line saying why and what to
    install (tries a 32x24 frame of a one-sphere model)."""
    try:
        mujoco = _mujoco()
        m = mujoco.MjModel.from_xml_string(
            "<mujoco><worldbody><geom type='sphere' size='.1'/></worldbody></mujoco>"
        )
        d = mujoco.MjData(m)
        mujoco.mj_forward(m, d)
        r = mujoco.Renderer(m, 24, 32)
        try:
            r.update_scene(d)
            r.render()
        finally:
            r.close()
    except Exception as e:  # any backend failure: the reason, on one line
        why = " ".join(f"{type(e).__name__}: {e}".split())[:300]
        return (
            f"MuJoCo cannot render offscreen with MUJOCO_GL="
            f"{os.environ.get('MUJOCO_GL', '')!r} ({why}); on Debian install libegl1 "
            "libegl-mesa0 libgl1-mesa-dri libopengl0 (as .ci/run does) and use "
            "MUJOCO_GL=egl, or libosmesa6 and MUJOCO_GL=osmesa"
        )
    return None


def fetch_camera() -> dict:
    """The free camera of the Fetch tasks' own render (gymnasium-robotics'
    `fetch_env.DEFAULT_CAMERA_CONFIG`, which `MujocoRenderer` applies): distance,
    azimuth, elevation, lookat."""
    import contextlib
    import io
    import warnings

    # gymnasium_robotics prints a notice about Adroit envs on its first import
    with (
        contextlib.redirect_stdout(io.StringIO()),
        contextlib.redirect_stderr(io.StringIO()),
        warnings.catch_warnings(),
    ):
        warnings.simplefilter("ignore")
        from gymnasium_robotics.envs.fetch.fetch_env import DEFAULT_CAMERA_CONFIG

    return {k: np.copy(v) for k, v in DEFAULT_CAMERA_CONFIG.items()}


@dataclass
class Frames:
    """The frames of one episode and what happened in it."""

    images: np.ndarray  # (F, H, W, 3) uint8
    fps: float  # frames per second when played
    env_id: str
    seed: int  # the env's seed (`envs.make_env`); the episode: its next reset
    steps: int  # env steps in the episode
    every: int  # env steps per frame
    success: bool  # the env's own rule at the last step
    distances: np.ndarray  # (k,) metres: each block (Reach: the gripper) to its target
    hold: float = 1.0  # seconds the last frame stays when played
    dt: float = 0.04  # simulated seconds per env step
    targets: tuple = ("red",)  # each target's colour, in the goal's order

    def __len__(self) -> int:
        return len(self.images)

    @property
    def speed(self) -> float:
        """Playback speed relative to the simulation (1: real time)."""
        return self.every * self.dt * self.fps

    def outcome(self, short: bool = False) -> str:
        """One line: success or failure at the last step, and each distance; `short`:
        without the step and the rule (the frame's label)."""
        word = "success" if self.success else "failure"
        if len(self.distances) == 1:
            what = "gripper" if self.env_id.startswith("FetchReach") else "block"
            text = f"{word}: {what} {100 * self.distances[0]:.1f} cm from target"
        else:
            cm = ", ".join(
                f"{100 * d:.1f} cm ({c})" for d, c in zip(self.distances, self.targets)
            )
            text = f"{word}: blocks {cm} from their targets"
        if short:
            return text
        return (
            f"{text} at step {self.steps} (success: every distance under "
            f"{100 * TOLERANCE:g} cm)"
        )


def _target_sites(mujoco, model, n: int) -> list[int]:
    ids = [
        mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_SITE, f"target{i}")
        for i in range(n)
    ]
    if min(ids) < 0:
        raise ValueError(f"the model has no sites target0..target{n - 1}")
    return ids


def render_states(
    env,
    states: np.ndarray,
    goal: np.ndarray,
    width: int = 320,
    height: int = 240,
    marker: bool = True,
) -> np.ndarray:
    """(F, height, width, 3) uint8: one frame per stored full state (`envs.get_state`)
    of `env`, seen from the Fetch camera, with the targets at `goal` (3k numbers, k
    targets). `marker=False` hides the targets and their balls. The env's state is put
    back, and its model too (target sites, mocap helper colours, offscreen size),
    afterwards."""
    mujoco = _mujoco()
    from acder_lite.envs import fetch as E

    m, d = env.model, env.data
    goal = np.asarray(goal, np.float64).ravel()
    targets = _target_sites(mujoco, m, goal.size // 3)
    saved_state, saved_goal = E.get_state(env), np.copy(env.goal)
    saved_site = (np.copy(m.site_pos), np.copy(m.site_rgba))
    saved_geom = np.copy(m.geom_rgba)
    saved_off = (m.vis.global_.offwidth, m.vis.global_.offheight)
    helpers = [i for i in range(m.ngeom) if m.body_mocapid[m.geom_bodyid[i]] >= 0]
    colours = [np.copy(m.site_rgba[s]) for s in targets]
    m.geom_rgba[helpers, 3] = 0.0
    if not marker:
        m.site_rgba[targets, 3] = 0.0
    cam = mujoco.MjvCamera()
    mujoco.mjv_defaultFreeCamera(m, cam)
    for k, v in fetch_camera().items():
        if np.ndim(v):
            getattr(cam, k)[:] = v
        else:
            setattr(cam, k, v)
    xray = mujoco.MjvOption()  # the second pass: sites only
    xray.geomgroup[:] = 0
    site_type = int(mujoco.mjtObj.mjOBJ_SITE)
    out = np.empty((len(states), height, width, 3), np.uint8)
    m.vis.global_.offwidth = max(m.vis.global_.offwidth, width)
    m.vis.global_.offheight = max(m.vis.global_.offheight, height)
    r = mujoco.Renderer(m, height, width)
    try:
        env.goal = goal
        for f, s in enumerate(states):
            E.set_state(env, s)
            env._render_callback()  # the env's own: target sites to the goal
            r.update_scene(d, cam)
            scn = r.scene
            for i, site in enumerate(targets if marker else []):
                if scn.ngeom >= scn.maxgeom:
                    break
                rgba = np.array(colours[i], np.float32)
                rgba[3] = 0.25
                mujoco.mjv_initGeom(
                    scn.geoms[scn.ngeom],
                    mujoco.mjtGeom.mjGEOM_SPHERE,
                    np.array([TOLERANCE, 0, 0]),
                    d.site_xpos[site],
                    np.eye(3).ravel(),
                    rgba,
                )
                scn.ngeom += 1
            out[f] = r.render()
            if marker:  # the targets seen through what hides them
                r.enable_segmentation_rendering()
                r.update_scene(d, cam, scene_option=xray)
                seg = r.render()
                r.disable_segmentation_rendering()
                for i, site in enumerate(targets):
                    on = (seg[..., 0] == site) & (seg[..., 1] == site_type)
                    blend = (1 - XRAY) * out[f][on] + XRAY * 255 * colours[i][:3]
                    out[f][on] = np.round(blend).astype(np.uint8)
    finally:
        r.close()
        m.site_pos[:], m.site_rgba[:] = saved_site
        m.geom_rgba[:] = saved_geom
        m.vis.global_.offwidth, m.vis.global_.offheight = saved_off
        env.goal = saved_goal
        E.set_state(env, saved_state)
    return out


def start_solved(env_id: str, seed: int) -> bool:
    """Whether the episode `render_episode` shows for `seed` starts solved (every block,
    on FetchReach the gripper, already within the success radius of its target): such
    an episode shows nothing of the policy. Decided from the start alone, before any
    action."""
    from acder_lite.envs import fetch as E

    env = E.make_env(env_id, seed=seed)
    try:
        obs, _ = env.reset()  # the reset run_episodes does
        ok = E.successes(env, obs["achieved_goal"][None], obs["desired_goal"][None])
        return bool(ok[0])
    finally:
        env.close()


def first_unsolved_seed(env_id: str, first: int = FIRST_TEST_SEED, tries: int = 20):
    """(seed, skipped): the first seed from `first` on whose episode does not start
    solved (`start_solved`), and the seeds passed over. A rule on the start state only,
    fixed before any rollout: the episode is not picked by its outcome."""
    skipped = []
    for seed in range(first, first + tries):
        if not start_solved(env_id, seed):
            return seed, skipped
        skipped.append(seed)
    raise ValueError(f"{env_id}: seeds {first}..{first + tries - 1} all start solved")


def _label(images: np.ndarray, lines: list[str]) -> None:
    """Draw `lines[i]` on frame i, in place (top left, dark grey on the green sky)."""
    from PIL import Image, ImageDraw, ImageFont

    h = images.shape[1]
    try:
        font = ImageFont.load_default(size=max(10, h // 20))
    except TypeError:  # Pillow without FreeType: the bitmap font
        font = ImageFont.load_default()
    for i, text in enumerate(lines):
        im = Image.fromarray(images[i])
        ImageDraw.Draw(im).text((6, 4), text, fill=(20, 40, 25), font=font)
        images[i] = np.asarray(im)


def render_episode(
    policy,
    seed: int = FIRST_TEST_SEED,
    width: int = 320,
    height: int = 240,
    fps: float = 12.5,
    *,
    env_id: str | None = None,
    steps: int | None = None,
    every: int = 1,
    hold: float = 1.0,
    label: bool = True,
    marker: bool = True,
) -> Frames:
    """One episode of `policy`, rendered: a run folder or policy file (its
    deterministic actor, `io.load_policy`, in the env and observation set it was
    trained on), or None for uniformly random actions on `env_id` (seeded by `seed`).

    The env is made with `seed` and rolled out by `run_episodes` (its first reset
    after seeding: the episode a trainer's test env of that seed runs first), for
    `steps` steps (default: the task's horizon). One frame every `every` steps, plus the
    last; played at `fps` frames per second, the last held `hold` seconds. `label`
    writes the task, seed and step on each frame and the outcome on the last;
    `marker=False` hides the targets."""
    from acder_lite.envs import fetch as E
    from acder_lite.train.rollout import run_episodes

    method = "random"
    if policy is None:
        if env_id is None:
            raise ValueError("render_episode: policy=None needs env_id")
        env = E.make_env(env_id, seed=seed)
        rng = np.random.default_rng(seed)
        high = env.action_space.high
        act = lambda o, g: rng.uniform(-high, high, (len(o), high.size))  # noqa: E731
    else:
        from acder_lite.io import load_policy
        from acder_lite.train.rollout import Policy

        pol, path = load_policy(str(policy))
        if env_id is not None and env_id != pol["env"]:
            raise ValueError(f"{path} was trained on {pol['env']}, not {env_id}")
        env_id, method = pol["env"], pol["method"]
        env = E.policy_env(pol, path, seed=seed)
        act = Policy.from_state_dict(pol)
    try:
        T = steps or E.horizon(env_id)
        ep = {k: v[0] for k, v in run_episodes([env], act, T).items()}
        keep = np.unique(np.r_[np.arange(0, T + 1, every), T])
        images = render_states(
            env, ep["state"][keep], ep["g"][-1], width, height, marker
        )
        dt = float(env.dt)
        names = tuple(
            ("red", "green", "blue")[int(np.argmax(env.model.site_rgba[i][:3]))]
            for i in _target_sites(_mujoco(), env.model, ep["g"].shape[-1] // 3)
        )
    finally:
        env.close()
    dist = np.linalg.norm((ep["ag"][-1] - ep["g"][-1]).reshape(-1, 3), axis=1)
    frames = Frames(
        images, fps, env_id, seed, T, every, bool(ep["success"]), dist, hold, dt, names
    )
    if label:
        head = f"{env_id}  {method}  seed {seed}"
        lines = [f"{head}  step {t}/{T}" for t in keep]
        lines[-1] = f"{head}  step {T}/{T}\n{frames.outcome(short=True)}"
        _label(frames.images, lines)
    return frames


def write_video(frames, path: str, fps: float | None = None, colors: int = 128) -> int:
    """Write `frames` (a `Frames`, or an (F, H, W, 3) uint8 array with `fps`) as an
    animated image that loops: `.gif` (one palette of `colors` colours for all frames,
    no dithering) or `.webp` (lossy, quality 80). Returns the file's size in bytes."""
    from PIL import Image

    if isinstance(frames, Frames):
        images, fps, hold = frames.images, fps or frames.fps, frames.hold
    else:
        images, hold = np.asarray(frames), 0.0
        if fps is None:
            raise ValueError("write_video: an array of frames needs fps")
    if images.ndim != 4 or images.shape[-1] != 3 or images.dtype != np.uint8:
        raise ValueError(
            f"write_video: frames must be (F, H, W, 3) uint8, got "
            f"{images.shape} {images.dtype}"
        )
    ext = os.path.splitext(path)[1].lower()
    ms = int(round(1000 / fps))
    durations = [ms] * len(images)
    durations[-1] = ms + int(round(1000 * hold))
    pics = [Image.fromarray(im) for im in images]
    os.makedirs(os.path.dirname(os.path.abspath(path)), exist_ok=True)
    if ext == ".gif":
        # one palette from a sample of frames side by side, then each frame mapped
        sample = images[np.linspace(0, len(images) - 1, 8).astype(int)]
        strip = Image.fromarray(np.concatenate(list(sample), axis=1))
        palette = strip.quantize(colors, method=Image.Quantize.MEDIANCUT)
        pics = [p.quantize(palette=palette, dither=Image.Dither.NONE) for p in pics]
        options = dict(optimize=False, disposal=1)
    elif ext == ".webp":
        options = dict(quality=80, method=6)
    else:
        raise ValueError(f"write_video: {path!r}: allowed suffixes .gif, .webp")
    pics[0].save(
        path,
        save_all=True,
        append_images=pics[1:],
        duration=durations,
        loop=0,
        **options,
    )
    return os.path.getsize(path)


def main(argv=None) -> int:
    """`python -m acder_lite.book.video RUN OUT.gif [--seed S]`: render one episode of
    the run's policy and print the file, its size and the episode's outcome."""
    p = argparse.ArgumentParser(prog="python -m acder_lite.book.video")
    p.add_argument("policy", help="run folder or policy .pt")
    p.add_argument("out", help="output file: .gif or .webp")
    p.add_argument(
        "--seed",
        default="first-unsolved",
        help="env seed (default: the first from 500 on whose episode does not start "
        "solved, first_unsolved_seed)",
    )
    p.add_argument("--width", type=int, default=320)
    p.add_argument("--height", type=int, default=240)
    p.add_argument("--fps", type=float, default=12.5)
    p.add_argument("--every", type=int, default=1)
    args = p.parse_args(argv)
    why = gl_problem()
    if why:
        print(f"video: {why}", file=sys.stderr)
        return 2
    skipped = []
    if args.seed == "first-unsolved":
        from acder_lite.io import load_policy

        env_id = load_policy(args.policy)[0]["env"]
        seed, skipped = first_unsolved_seed(env_id)
    else:
        seed = int(args.seed)
    frames = render_episode(
        args.policy, seed, args.width, args.height, args.fps, every=args.every
    )
    size = write_video(frames, args.out)
    passed = f"; seeds {skipped} start solved, skipped" if skipped else ""
    print(
        f"{args.out}: {size / 1e3:.0f} kB, {len(frames)} frames "
        f"{args.width}x{args.height} at {args.fps:g} fps ({frames.speed:g}x real "
        f"time), {frames.env_id} seed {seed}{passed}: {frames.outcome()} "
        f"[MUJOCO_GL={os.environ.get('MUJOCO_GL', '')}]"
    )
    return 0


if __name__ == "__main__":
    sys.exit(main())
