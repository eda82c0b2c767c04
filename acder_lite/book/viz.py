"""Meshcat scenes of the Fetch tasks, built from the MuJoCo model itself (for the book).

A `Recording` is a list of frames; each frame holds the world pose of every visible geom
(`data.geom_xpos`, `data.geom_xmat`) and the goal. Frames come from full MuJoCo states
(`record_states`), so anything that can be stored as a state — a rollout, the start
states of chapter 6 — can be shown. `scene_from_recording` turns a recording into a
Meshcat scene: meshes from `model.mesh_vert`/`mesh_face` (decimated by vertex clustering
to keep the page small), primitives for boxes, spheres, cylinders, capsules and the
floor plane, colours from `geom_rgba` or the geom's material, the goal as the model's
`target0` site (a 6-D goal, the multi-step push's two blocks, as its `target0` and
`target1` sites, each in the XML's colour), and one animation track per moving geom.
`save_scene_html` writes Meshcat's self-contained static page (three.js inlined, no
network), and `show_scene` embeds a saved page in a notebook with an iframe.
"""

from __future__ import annotations

import itertools

import os
from dataclasses import dataclass, field

import mujoco
import numpy as np

from acder_lite.envs import fetch as E

SCENE_DIR = os.path.join("book", "_static", "scenes")
"""Where scenes go, relative to the repo root
(Jupyter Book copies `book/_static` into the site)."""

FOCUS = np.array([1.1, 0.75, 0.45])
"""World point (the table, in front of the robot) moved to the viewer's origin,
where the camera looks."""

CAMERA = (0.8, 1.0, 0.75)
"""Camera position relative to FOCUS, in world axes (x forward from the robot, z up)."""

_DEFAULT_RGBA = np.array([0.5, 0.5, 0.5, 1.0])


@dataclass
class Recording:
    """Frames of a Fetch scene: per frame the pose of every geom, and the goal."""

    model: mujoco.MjModel
    xpos: np.ndarray  # (F, ngeom, 3)
    xmat: np.ndarray  # (F, ngeom, 3, 3)
    goal: np.ndarray  # (F, 3k): k targets (k = 2 on the multi-step push)
    dt: float  # seconds between frames
    episode: dict = field(
        default_factory=dict
    )  # the rollout's arrays, if recorded from one

    @property
    def n_frames(self) -> int:
        return self.xpos.shape[0]


def record_states(
    env, states: np.ndarray, goals: np.ndarray, dt: float | None = None
) -> Recording:
    """One frame per stored full MuJoCo state (`envs.get_state`);
    the env is put back afterwards.

    `goals`: one goal for all frames, (3k,), or one per frame, (F, 3k), k targets of 3
    numbers."""
    states = np.asarray(states, np.float64)
    goals = np.asarray(goals, np.float64)
    if goals.ndim not in (1, 2) or goals.shape[-1] % 3 or not goals.shape[-1]:
        raise ValueError(
            f"record_states: goals must be (3k,) or (F, 3k), got {goals.shape}"
        )
    goals = np.broadcast_to(goals, (len(states), goals.shape[-1]))
    saved = E.get_state(env)
    m, d = env.model, env.data
    xpos = np.empty((len(states), m.ngeom, 3))
    xmat = np.empty((len(states), m.ngeom, 3, 3))
    for i, s in enumerate(states):
        E.set_state(env, s)
        xpos[i] = d.geom_xpos
        xmat[i] = d.geom_xmat.reshape(-1, 3, 3)
    E.set_state(env, saved)
    return Recording(
        m, xpos, xmat, np.array(goals), float(env.dt if dt is None else dt)
    )


def record_rollout(
    env, policy=None, steps: int | None = None, seed: int | None = None, every: int = 2
) -> Recording:
    """Roll out one episode (the trainer's own `run_episodes`) and record every
    `every`-th step.

    `policy(o, g) -> u` acts on batches (a `rollout.Policy` does); None acts uniformly
    at random. `recording.episode` keeps the rollout's arrays (o, ag, g, u, state,
    success) for one env.
    """
    from acder_lite.train.rollout import run_episodes

    T = steps or E.horizon(env.spec.id if env.spec else "FetchReach-v4")
    if seed is not None:
        env.reset(seed=seed)
    rng = np.random.default_rng(seed)
    high = env.action_space.high
    act = (
        policy
        if policy is not None
        else (lambda o, g: rng.uniform(-high, high, (len(o), high.size)))
    )
    ep = run_episodes([env], act, T)
    ep = {k: v[0] for k, v in ep.items()}
    keep = np.unique(np.r_[np.arange(0, T + 1, every), T])
    goals = np.concatenate([ep["g"], ep["g"][-1:]])[keep]
    rec = record_states(env, ep["state"][keep], goals, env.dt * every)
    rec.episode = ep
    return rec


# ----- geometry


def _rgba(m, i: int) -> np.ndarray:
    """MuJoCo's rule: a geom's material colour applies unless the geom sets
    its own rgba."""
    mat = m.geom_matid[i]
    if mat >= 0 and np.allclose(m.geom_rgba[i], _DEFAULT_RGBA):
        return np.array(m.mat_rgba[mat])
    return np.array(m.geom_rgba[i])


def geom_rgba(m, i: int) -> np.ndarray:
    """The colour the scene gives geom i (MuJoCo's rule, as `_rgba`), e.g.
    for a matching 2-D figure."""
    return _rgba(m, i)


def visible_geoms(m) -> list[int]:
    """Geoms a viewer shows: groups 0-2, opaque enough,
    not the mocap target's helper boxes."""
    out = []
    for i in range(m.ngeom):
        body = m.geom_bodyid[i]
        if m.geom_group[i] >= 3 or _rgba(m, i)[3] < 0.5 or m.body_mocapid[body] >= 0:
            continue
        out.append(i)
    return out


def decimate(
    verts: np.ndarray, faces: np.ndarray, cell: float
) -> tuple[np.ndarray, np.ndarray]:
    """Vertex clustering: merge the vertices in each cube of side `cell`,
    drop collapsed faces."""
    key = np.floor(verts / cell).astype(np.int64)
    _, inv = np.unique(key, axis=0, return_inverse=True)
    inv = inv.reshape(-1)
    n = inv.max() + 1
    new_v = np.zeros((n, 3))
    np.add.at(new_v, inv, verts)
    new_v /= np.bincount(inv, minlength=n)[:, None]
    f = inv[faces]
    ok = (f[:, 0] != f[:, 1]) & (f[:, 1] != f[:, 2]) & (f[:, 0] != f[:, 2])
    f = f[ok]
    _, first = np.unique(np.sort(f, axis=1), axis=0, return_index=True)
    return new_v.astype(np.float32), f[np.sort(first)].astype(np.uint32)


def mesh_arrays(
    m, mesh_id: int, cell: float | None = 0.012
) -> tuple[np.ndarray, np.ndarray]:
    """Vertices and faces of a model mesh (in its geom's frame),
    decimated if `cell` is given."""
    va, vn = m.mesh_vertadr[mesh_id], m.mesh_vertnum[mesh_id]
    fa, fn = m.mesh_faceadr[mesh_id], m.mesh_facenum[mesh_id]
    v = np.array(m.mesh_vert[va : va + vn], np.float64)
    f = np.array(m.mesh_face[fa : fa + fn], np.int64)
    if cell:
        v, f = decimate(v, f, cell)
    return v, f


def hex_color(rgba) -> int:
    r, g, b = (np.clip(np.asarray(rgba[:3]), 0, 1) * 255).round().astype(int)
    return int(r) << 16 | int(g) << 8 | int(b)


def _material(rgba):
    import meshcat.geometry as mg

    a = float(rgba[3])
    return mg.MeshLambertMaterial(color=hex_color(rgba), opacity=a, transparent=a < 1)


def _rot_x(angle: float) -> np.ndarray:
    c, s = np.cos(angle), np.sin(angle)
    T = np.eye(4)
    T[1:3, 1:3] = [[c, -s], [s, c]]
    return T


def _set_geom(node, m, i: int, cell: float | None) -> None:
    """Put geom i's shape under `node`, in the geom's own frame (three.js cylinders run
    along y, MuJoCo's along z, hence the extra rotation)."""
    import meshcat.geometry as mg

    t, size, mat = m.geom_type[i], m.geom_size[i], _material(_rgba(m, i))
    G = mujoco.mjtGeom
    if t == G.mjGEOM_MESH:
        v, f = mesh_arrays(m, m.geom_dataid[i], cell)
        _set_object(node, mg.TriangularMeshGeometry(v, f), mat)
    elif t == G.mjGEOM_BOX:
        _set_object(node, mg.Box(2 * size), mat)
    elif t == G.mjGEOM_SPHERE:
        _set_object(node, mg.Sphere(size[0]), mat)
    elif t == G.mjGEOM_ELLIPSOID:
        _set_object(node, mg.Ellipsoid(size[:3]), mat)
    elif t in (G.mjGEOM_CYLINDER, G.mjGEOM_CAPSULE):
        _set_object(node["body"], mg.Cylinder(2 * size[1], size[0]), mat)
        node["body"].set_transform(_rot_x(np.pi / 2))
        if t == G.mjGEOM_CAPSULE:
            for k, z in (("cap0", -size[1]), ("cap1", size[1])):
                _set_object(node[k], mg.Sphere(size[0]), mat)
                T = np.eye(4)
                T[2, 3] = z
                node[k].set_transform(T)
    elif t == G.mjGEOM_PLANE:
        sx, sy = (s if s > 0 else 5.0 for s in size[:2])
        _set_object(node["plane"], mg.Box([2 * sx, 2 * sy, 0.01]), mat)
        T = np.eye(4)
        T[2, 3] = -0.005
        node["plane"].set_transform(T)


def _set_object(node, geometry, material) -> None:
    """`node.set_object` with uuids derived from the node's path instead of random ones,
    so a scene written twice from the same rollout is the same file (no noise in git
    diffs)."""
    import uuid

    import meshcat.geometry as mg

    path = node.path.lower()
    obj = mg.Mesh(geometry, material)
    for part, name in ((geometry, "geometry"), (material, "material"), (obj, "object")):
        part.uuid = str(uuid.uuid5(uuid.NAMESPACE_URL, f"{path}#{name}"))
    node.set_object(obj)


def _pose(pos, mat) -> np.ndarray:
    T = np.eye(4)
    T[:3, :3] = mat
    T[:3, 3] = pos
    return T


def _site(m, name: str):
    i = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_SITE, name)
    return (
        (float(m.site_size[i][0]), np.array(m.site_rgba[i]))
        if i >= 0
        else (0.02, np.array([1, 0, 0, 1.0]))
    )


def target_nodes(goal_size: int) -> list[tuple[str, str, slice]]:
    """(scene node, model site, goal columns) of each target marker: one 3-D goal is the
    node `target` drawn as the site `target0` (as always); a 3k-D goal gives nodes
    `target0` ... drawn as sites `target0` ... (FetchPushMultiStep-v0: red target0 for
    block 0, blue target1 for block 1, `multistep.TARGETS`)."""
    k = goal_size // 3
    if k == 1:
        return [("target", "target0", slice(0, 3))]
    return [(f"target{i}", f"target{i}", slice(3 * i, 3 * i + 3)) for i in range(k)]


def scene_from_recording(
    rec: Recording,
    vis=None,
    cell: float | None = 0.012,
    markers=None,
    marker_colors=None,
    marker_radius: float = 0.012,
    loop: int = 1000,
):
    """Build (or add to) a Meshcat visualizer showing `rec`,
    animated when it has several frames.

    `markers` (N, 3) world points drawn as small spheres with `marker_colors` (N, 3) in
    [0, 1] (e.g. curiosity along a rollout). Returns the visualizer.
    """
    import meshcat.geometry as mg
    from meshcat.animation import Animation

    if vis is None:
        vis = new_visualizer()
    m = rec.model
    root = vis["fetch"]
    shift = np.eye(4)
    shift[:3, 3] = -FOCUS
    root.set_transform(shift)
    vis["/Grid"].set_property("visible", False)
    vis["/Axes"].set_property("visible", False)
    cx, cy, cz = CAMERA
    vis["/Cameras/default/rotated/<object>"].set_property(
        "position", [cx, cz, -cy]
    )  # y-up frame

    anim = Animation(default_framerate=max(1, round(1 / rec.dt)))
    F = rec.n_frames
    for i in visible_geoms(m):
        node = root[f"geom{i}"]
        _set_geom(node, m, i, cell)
        node.set_transform(_pose(rec.xpos[0, i], rec.xmat[0, i]))
        moving = F > 1 and (
            np.ptp(rec.xpos[:, i], axis=0).max() > 1e-6
            or np.ptp(rec.xmat[:, i], axis=0).max() > 1e-6
        )
        if moving:
            for k in range(F):
                with anim.at_frame(vis, k) as frame:
                    frame["fetch"][f"geom{i}"].set_transform(
                        _pose(rec.xpos[k, i], rec.xmat[k, i])
                    )
    for name, site, cols in target_nodes(rec.goal.shape[1]):
        radius, rgba = _site(m, site)
        target = root[name]
        _set_object(target, mg.Sphere(radius), _material(rgba))
        goal = rec.goal[:, cols]
        target.set_transform(_pose(goal[0], np.eye(3)))
        if F > 1 and np.ptp(goal, axis=0).max() > 1e-9:
            for k in range(F):
                with anim.at_frame(vis, k) as frame:
                    frame["fetch"][name].set_transform(_pose(goal[k], np.eye(3)))
    if markers is not None:
        add_markers(vis, markers, marker_colors, marker_radius)
    if anim.clips:
        vis.set_animation(anim, play=True, repetitions=loop)
    return vis


def pool_scene(
    env,
    states: np.ndarray,
    goals: np.ndarray,
    markers: np.ndarray,
    dt: float = 0.5,
    color=(0.1, 0.7, 0.2),
    radius: float = 0.008,
):
    """A Meshcat scene stepping through stored start states (chapter 6), one frame per
    state `dt` seconds apart, each with its own goal, plus a sphere of `color` at every
    point of `markers` (N, 3; e.g. each state's gripper position,
    `diagnose.pool_positions`), all shown at once. Returns the visualizer."""
    rec = record_states(env, states, goals, dt=dt)
    markers = np.asarray(markers, float).reshape(-1, 3)
    colors = np.tile(np.asarray(color, float), (len(markers), 1))
    return scene_from_recording(
        rec, markers=markers, marker_colors=colors, marker_radius=radius
    )


_MESHCAT_SERVER = """
import sys
import tornado.web
_listen = tornado.web.Application.listen
# meshcat passes no address: tornado would take all
def listen(self, port, address=None, **kwargs):
    return _listen(self, port, address or "127.0.0.1", **kwargs)
tornado.web.Application.listen = listen
from meshcat.servers import zmqserver
sys.argv = ["meshcat-server"]
zmqserver.main()
"""
"""Meshcat's own server (`python -m meshcat.servers.zmqserver`), with its web server
bound to 127.0.0.1: meshcat 0.3 binds ZeroMQ to 127.0.0.1 but calls tornado's
`Application.listen(port)` without an address, which listens on every interface (0.0.0.0
and ::)."""


def _start_local_meshcat_server():
    """Start `_MESHCAT_SERVER` as meshcat's `start_zmq_server_as_subprocess` does;
    (proc, zmq_url)."""
    import atexit
    import subprocess
    import sys

    from meshcat.servers.zmqserver import match_zmq_url

    proc = subprocess.Popen(
        [sys.executable, "-u", "-P", "-c", _MESHCAT_SERVER],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        start_new_session=True,
    )
    line = ""
    while "zmq_url" not in line:
        line = proc.stdout.readline().strip().decode("utf-8")
        if proc.poll() is not None:
            err = proc.stderr.read().decode("utf-8", "replace").strip().splitlines()
            raise RuntimeError(
                "the meshcat server exited at start (code %s): %s"
                % (proc.returncode, err[-1:] or "")
            )
    # web_url=..., which the visualizer asks the server for again
    proc.stdout.readline()

    def cleanup(p=proc):
        if p.poll() is None:
            p.kill()
            p.wait()

    atexit.register(cleanup)
    return proc, match_zmq_url(line)


def new_visualizer():
    """`meshcat.Visualizer()` on a local server that listens on 127.0.0.1 only (ZeroMQ
    and the web page), without its "open the URL" print. `close_visualizer` stops the
    server."""
    import contextlib
    import io

    import meshcat
    from meshcat.visualizer import ViewerWindow

    proc, zmq_url = _start_local_meshcat_server()
    try:
        with contextlib.redirect_stdout(io.StringIO()):
            window = ViewerWindow(zmq_url=zmq_url, start_server=False, server_args=[])
    except BaseException:
        proc.kill()
        proc.wait()
        raise
    window.server_proc = proc
    return meshcat.Visualizer(window=window)


def add_markers(
    vis, points, colors=None, radius: float = 0.012, name: str = "markers"
) -> None:
    """Small spheres at world `points` (N, 3), coloured by `colors` (N, 3) in [0, 1]."""
    import meshcat.geometry as mg

    points = np.asarray(points, float).reshape(-1, 3)
    colors = (
        np.full((len(points), 3), [1.0, 0.5, 0.0])
        if colors is None
        else np.asarray(colors, float)
    )
    vis["fetch"][name].delete()
    for k, (p, c) in enumerate(zip(points, colors)):
        node = vis["fetch"][name][f"m{k}"]
        _set_object(node, mg.Sphere(radius), _material(np.r_[c[:3], 1.0]))
        node.set_transform(_pose(p, np.eye(3)))


def save_scene_html(vis, path: str) -> int:
    """Write the visualizer's self-contained page to `path` atomically;
    returns its size in bytes. A page that cannot be written (a full disk, a read-only
    folder) raises `io.WriteError`, one line naming it: the page there before is whole,
    and no temporary file is left.

    Meshcat's `static_html()` inlines three.js and the scene, so the page needs no
    network.
    """
    html = vis.static_html()
    if "https://" in html.split("<script>", 1)[0]:
        raise RuntimeError("scene page references the network")
    from acder_lite.io import atomic_write

    atomic_write(path, lambda f: f.write(html.encode("utf-8")))
    return os.path.getsize(path)


def scene_commands(html: str) -> list[dict]:
    """The Meshcat commands a saved static page replays (set_object, set_transform,
    ...), decoded from its base64 msgpack blobs: what a test or a reader can check a
    page holds without WebGL."""
    import base64
    import re

    import umsgpack  # meshcat's own encoder (u-msgpack-python, one of its requirements)

    blobs = re.findall(r"data:application/octet-binary;base64,([A-Za-z0-9+/=]+)", html)
    return [umsgpack.unpackb(base64.b64decode(b)) for b in blobs]


def scene_objects(html: str) -> set[str]:
    """Paths of the objects a saved static page draws
    (`/meshcat/fetch/target0`, ...)."""
    return {
        c["path"]
        for c in scene_commands(html)
        if isinstance(c, dict) and c.get("type") == "set_object"
    }


def repo_root() -> str:
    """The repo root (the directory holding `acder_lite/`; this file is
    acder_lite/book/viz.py)."""
    return os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))


def scene_path(name: str) -> str:
    """Absolute path of scene `name` (without .html) under book/_static/scenes/."""
    return os.path.join(repo_root(), SCENE_DIR, f"{name}.html")


def save_scene(vis, name: str, close: bool = True) -> str:
    """Save `vis` as book/_static/scenes/NAME.html, close its server (unless
    `close=False`), and return the absolute path."""
    path = scene_path(name)
    try:
        save_scene_html(vis, path)
    finally:  # a page that could not be written leaves no Meshcat server running
        if close:
            close_visualizer(vis)
    return path


def close_visualizer(vis) -> None:
    """Stop the local Meshcat server a `meshcat.Visualizer()` started."""
    try:
        vis.close()
    except Exception:
        pass
    server = getattr(getattr(vis, "window", None), "server_proc", None)
    if server is not None:
        try:
            server.kill()
            server.wait(timeout=5)
        except Exception:
            pass


_SCENE_IDS = itertools.count()
"""Numbers the scene frames of a page (the same scene may be shown twice)."""


def show_scene(name: str, height: int = 480):
    """An iframe showing book/_static/scenes/NAME.html, for a notebook under notebooks/.

    The src `../_static/scenes/NAME.html` is relative to the built page: chapters land
    in _build/html/notebooks/ and _config.yml's `html_static_path: [book/_static]`
    copies the scenes to _build/html/_static/scenes/. Trap: in JupyterLab (`make lab`)
    the same relative src lands on /lab/tree/_static/..., which is Lab's own page; there
    a line of script points the frame at the file server instead
    (/files/book/_static/scenes/NAME.html, under Lab's base URL).
    """
    import html

    from IPython.display import HTML

    fid = f"scene-{name}-{next(_SCENE_IDS)}"
    src = f"../_static/scenes/{name}.html"
    lab = f"/files/book/_static/scenes/{name}.html"
    return HTML(
        f'<iframe id="{fid}" src="{html.escape(src)}" width="100%" '
        f'height="{int(height)}" frameborder="0"></iframe><script>(function () {{ var '
        'p = window.location.pathname, i = p.indexOf("/lab/"); if (i >= 0) '
        f'document.getElementById("{fid}").src = p.slice(0, i) + "{lab}"; '
        f"}})();</script>"
    )
