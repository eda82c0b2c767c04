"""The package's layers, read from its imports (every `import`, at the top of a module
or inside a function): a folder imports only from the folders below it, no two modules
import each other through any chain, and no module imports another's private name."""

import ast
import pathlib

import pytest

ROOT = pathlib.Path(__file__).resolve().parents[1] / "acder_lite"
LAYERS = ["", "algo", "envs", "stats", "runs", "train", "deploy", "cli", "book"]
"""Bottom to top; "" is the top-level modules (config, legacy, io, precision,
signals, words)."""


def modules() -> dict[str, pathlib.Path]:
    out = {}
    for path in ROOT.rglob("*.py"):
        rel = path.relative_to(ROOT).with_suffix("")
        parts = list(rel.parts)
        if parts[-1] == "__init__":
            parts = parts[:-1]
        out[".".join(["acder_lite", *parts])] = path
    return out


MODULES = modules()


def imports(name: str) -> list[tuple[str, str | None, int]]:
    """(module imported, name taken from it or None, line) for each import of `name`."""
    tree = ast.parse(MODULES[name].read_text())
    out = []
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            out += [(a.name, None, node.lineno) for a in node.names]
        elif isinstance(node, ast.ImportFrom):
            assert node.level == 0, f"{name}:{node.lineno}: relative import"
            for a in node.names:
                sub = f"{node.module}.{a.name}"
                if sub in MODULES:  # `from acder_lite.algo import rewards`
                    out.append((sub, None, node.lineno))
                else:
                    out.append((node.module, a.name, node.lineno))
    return [(m, n, line) for m, n, line in out if m.split(".")[0] == "acder_lite"]


def layer(name: str) -> int:
    parts = name.split(".")
    folder = (
        parts[1] if len(parts) > 2 or (len(parts) == 2 and parts[1] in LAYERS) else ""
    )
    return LAYERS.index(folder)


PACKAGE_MODULES = [m for m in MODULES if m not in ("acder_lite", "acder_lite.__main__")]


def test_every_module_sits_in_a_known_layer():
    for name in PACKAGE_MODULES:
        layer(name)  # raises ValueError for a folder not in LAYERS
    assert len(MODULES) > 40  # the walk found the package


@pytest.mark.parametrize("name", PACKAGE_MODULES)
def test_no_import_runs_up_a_layer(name):
    for target, _, line in imports(name):
        if target == "acder_lite":
            continue  # the package's own __init__: public names, imported lazily
        assert layer(target) <= layer(name), (
            f"{name}:{line} imports {target}, a layer above it"
        )


def test_no_import_circles():
    graph = {
        m: {t for t, _, _ in imports(m) if t in MODULES and t != "acder_lite"}
        for m in PACKAGE_MODULES
    }
    # packages import their own __init__ on the way; a folder's __init__ holds no code
    done, stack = set(), []

    def visit(m):
        if m in stack:
            cycle = stack[stack.index(m) :] + [m]
            raise AssertionError("import circle: " + " -> ".join(cycle))
        if m in done:
            return
        stack.append(m)
        for t in sorted(graph.get(m, ())):
            visit(t)
        stack.pop()
        done.add(m)

    for m in sorted(graph):
        visit(m)


@pytest.mark.parametrize("name", PACKAGE_MODULES)
def test_no_private_name_of_another_module(name):
    for target, taken, line in imports(name):
        if taken is not None and target != name:
            assert not taken.startswith("_"), (
                f"{name}:{line} imports {target}.{taken}, a private name"
            )


def test_tests_import_no_private_name():
    here = pathlib.Path(__file__).parent
    for path in sorted(here.glob("*.py")):
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, ast.ImportFrom) and (node.module or "").startswith(
                "acder_lite"
            ):
                private = [a.name for a in node.names if a.name.startswith("_")]
                assert not private, f"{path.name}:{node.lineno} imports {private}"


def test_old_flat_paths_still_import_the_moved_modules():
    """`import acder_lite.rewards` (the flat package's path) is the module at its new
    place, the same object."""
    import importlib

    import acder_lite

    for old, new in acder_lite.MOVED.items():
        if old in ("cli",):
            continue
        a = importlib.import_module(f"acder_lite.{old}")
        b = importlib.import_module(f"acder_lite.{new}")
        assert a is b, old
    from acder_lite.rewards import intrinsic_reward

    assert intrinsic_reward is acder_lite.intrinsic_reward


def test_paths_computed_from_a_module_file_reach_the_repository_root():
    """Modules that find the repository from their own file (the book's scenes, the
    sweep's PYTHONPATH for Ray workers) count the folder levels of their new place."""
    from acder_lite.book import viz

    root = pathlib.Path(viz.repo_root())
    assert (root / "acder_lite" / "__init__.py").is_file() and (
        root / "_toc.yml"
    ).is_file()
    assert pathlib.Path(viz.scene_path("x")).is_relative_to(root / "book")
    src = (ROOT / "cli" / "cluster.py").read_text()
    assert "Path(__file__).resolve().parents[2]" in src  # acder_lite/cli/ -> the repo
