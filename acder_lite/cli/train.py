"""The commands train, eval and bench, the options every command shares, and how a
command's errors become one line and an exit code (`run_main`).

`cli.main` adds the other commands; a sweep's cell runs its train command through
`run_main(base_parser, argv)`, so the two give the same lines and codes."""

from __future__ import annotations

import argparse
import dataclasses
import errno
import os
import sys

from acder_lite.config import (
    ENV_IDS,
    MAX_THREADS,
    METHODS,
    Config,
    ConfigError,
    field_docs,
)
from acder_lite.io import CheckpointError, WriteError, checkpoint_config, probe_write
from acder_lite.words import plural

# Config fields that are not command-line options.
_NOT_OPTIONS = {"switches", "update_dtype_why", "device_why"}
# Fields whose values are the keys of a table: --help lists them from the table, so a
# method or task added there shows up here with no docstring to edit.
_CHOICES = {"env": ENV_IDS, "method": METHODS}
# Fields a resumed run may change (everything else is fixed by the checkpoint).
_RESUMABLE = {
    "epochs",
    "threads",
    "step_threads",
    "split_update",
    "success_threshold",
    "stop_patience",
    "stop_gap_episodes",
    "device",
}  # device: the checkpoint loads onto the resumed run's


class UsageError(Exception):
    pass


COMMANDS = {
    "train": "train one (env, method, seed) into a run folder, or resume one",
    "eval": "a trained policy's success rate on deterministic test episodes",
    "bench": "time simulation, the update and a training episode here",
    "sweep": "train a grid of runs as Ray tasks, here or on a cluster",
    "pack": "shrink unfinished runs' checkpoints to commit them",
    "table": "Table I from the runs, beside the paper's numbers",
    "diagnose": "S-ICM's novelty, the start pool, how a policy moves the object",
    "robust": "a policy's success under a real arm's noise and delays",
    "export": "a policy as one TorchScript file that needs no acder_lite",
}
"""Each command's line in `python -m acder_lite --help`."""


class _Parser(argparse.ArgumentParser):
    """No abbreviated options (`--epoch 2` once silently meant --epochs), and a bad
    command line is one line naming the command, exit 2 (argparse would print the usage
    block too)."""

    def __init__(self, *args, **kwargs):
        kwargs["allow_abbrev"] = False
        super().__init__(*args, **kwargs)

    def error(self, message):
        raise UsageError(f"{self.prog}: {message}")

    def parse_args(self, args=None, namespace=None):
        args = _options_as_values(sys.argv[1:] if args is None else list(args))
        # argparse reports a subcommand's unknown options from the top parser, under
        # its name: say which command's they are, and the option meant if one is close
        ns, extras = self.parse_known_args(args, namespace)
        if extras:
            raise UsageError(_unrecognized(self, ns, extras))
        return ns


_OPTIONS_VALUED = ("--train-args",)
"""Options whose value is itself a command line (sweep's options for train)."""


def _options_as_values(argv: list[str]) -> list[str]:
    """`argv` with the value of an `_OPTIONS_VALUED` option joined to it by "=", so a
    value that starts with "-" is its value. Trap: argparse took `--train-args
    '--bogus'` for two options, "expected one argument", naming neither the value nor
    the option of train it is not."""
    out, i = [], 0
    while i < len(argv):
        if argv[i] == "--":  # the rest are values
            return out + argv[i:]
        if argv[i] in _OPTIONS_VALUED and i + 1 < len(argv):
            out.append(f"{argv[i]}={argv[i + 1]}")
            i += 2
        else:
            out.append(argv[i])
            i += 1
    return out


def _unrecognized(parser: argparse.ArgumentParser, ns, extras: list[str]) -> str:
    """One line: the command whose arguments `extras` are not, and for each unknown
    option a close one it has ("did you mean --epochs?")."""
    import difflib

    prog = parser.prog
    for a in parser._actions:
        if isinstance(a, argparse._SubParsersAction) and getattr(ns, a.dest, None):
            parser = a.choices[getattr(ns, a.dest)]
            prog = parser.prog
    # compared without the leading "--", which every option shares (`--bogus` is not
    # close to `--out`)
    names = [o[2:] for a in parser._actions for o in a.option_strings if o[:2] == "--"]
    hints = []
    for x in extras:
        flag = x.split("=", 1)[0]
        if flag.startswith("--"):
            close = difflib.get_close_matches(flag[2:], names, n=1)
            if close and "--" + close[0] not in hints:
                hints.append("--" + close[0])
    line = f"{prog}: unrecognized arguments: {' '.join(extras)}"
    if hints:
        line += "; did you mean " + " or ".join(hints) + "?"
    return line


def _field_type(f: dataclasses.Field):
    t = f.type if isinstance(f.type, str) else getattr(f.type, "__name__", str(f.type))
    if "int" in t and "float" not in t:
        return int
    if "float" in t:
        return float
    return str


def add_config_options(p: argparse.ArgumentParser) -> None:
    docs = field_docs()
    for f in dataclasses.fields(Config):
        if f.name in _NOT_OPTIONS:
            continue
        doc = docs.get(f.name, "").replace("%", "%%")
        if f.name in _CHOICES:
            doc += f" One of: {', '.join(_CHOICES[f.name])}."
        default = f.default if f.default is not dataclasses.MISSING else None
        if f.type in (bool, "bool"):  # a flag: given is True, absent is the default
            p.add_argument(
                "--" + f.name.replace("_", "-"),
                dest=f.name,
                action="store_true",
                default=None,
                help=f"{doc} (default: off)".strip(),
            )
            continue
        p.add_argument(
            "--" + f.name.replace("_", "-"),
            dest=f.name,
            type=_field_type(f),
            default=None,
            help=f"{doc} (default: {default})".strip(),
        )


def given_options(args) -> dict:
    """The Config fields a parsed `train` command line sets (the options given)."""
    return {
        f.name: getattr(args, f.name)
        for f in dataclasses.fields(Config)
        if f.name not in _NOT_OPTIONS and getattr(args, f.name, None) is not None
    }


def _command_line(argv: list[str] | None = None) -> list[str]:
    """The command as a reader would retype it: `argv` as given to `main` (a sweep's Ray
    task calls main in a worker whose sys.argv is Ray's), else sys.argv without the path
    of __main__.py."""
    import shlex

    argv = sys.argv[1:] if argv is None else argv
    return ["python", "-m", "acder_lite"] + [shlex.quote(a) for a in argv]


def cmd_train(args) -> int:
    from acder_lite.runs import packed
    from acder_lite.io import load_torch
    from acder_lite.train.trainer import Trainer

    given = given_options(args)
    for name in ("out", "resume"):  # "" was read as not given
        if getattr(args, name) == "":
            raise UsageError(f"train: --{name} '' is empty; allowed: a run folder")
    if args.resume and args.out:
        raise UsageError(
            f"train: --out {args.out!r} and --resume {args.resume!r} exclude each "
            "other; allowed: --out DIR for a new run, or --resume DIR to continue one"
        )
    if args.resume:
        _check_resume_folder(args.resume)
        _check_run_json(args.resume)  # before training: it is rewritten at the start
        _check_run_file_kinds(args.resume, "--resume")
        ckpt_path = os.path.join(args.resume, "checkpoint.pt")
        ckpt = load_torch(ckpt_path) if os.path.exists(ckpt_path) else None
        later, note = packed.later_than(args.resume, ckpt)
        if note:  # said with the warnings, once the options have passed
            note = f"resume: {note}; resuming from checkpoint.pt"
        packed_files = None
        if later:  # a run carried over from another machine: its buffer re-simulated
            # (`packed.unpack`, minutes) once its files are read whole and the options
            # checked against its state; until then `ckpt` is that state
            packed_files = packed.read(args.resume)
            ckpt = packed_files[0]
            ckpt_path = os.path.join(args.resume, packed.FOLDER)
        elif ckpt is None:
            if not os.path.exists(ckpt_path):
                raise CheckpointError(
                    f"train: --resume {args.resume!r} holds no checkpoint.pt (nor "
                    f"a packed {packed.FOLDER}/); allowed: a run folder train has "
                    "saved a checkpoint in (a run stopped in its first epoch has "
                    "none: start it again with --out)"
                )
            ckpt = load_torch(ckpt_path)  # the one-line error of an unreadable file
        # load_torch checked that a checkpoint has all its parts
        if "buffer" not in ckpt:
            raise CheckpointError(
                f"checkpoint {ckpt_path!r} holds a policy only, not the training state "
                "--resume needs; allowed: the checkpoint.pt that train writes"
            )
        cfg = checkpoint_config(ckpt, ckpt_path)
        for k, v in given.items():
            if k in _RESUMABLE:
                setattr(cfg, k, v)
                if k == "device":  # resolved again: the checkpoint's why is stale
                    cfg.device_why = ""
            elif v != getattr(cfg, k):
                raise ConfigError(
                    f"{k}={v!r} differs from the checkpoint's {getattr(cfg, k)!r}; "
                    f"a resumed run may change only: {', '.join(sorted(_RESUMABLE))}"
                )
        out = args.resume
        ended = _resume_budget(out, ckpt, cfg)
        if ended:  # not an error, and no file is rewritten
            if note:
                print(note, file=sys.stderr)
            print(ended)
            return 0
        try:
            probe_write(out)
        except OSError as e:
            raise UsageError(
                f"train: --resume {out!r} cannot be written ({e.strerror}); "
                "allowed: a run folder you can write to"
            ) from None
        if packed_files is not None:
            print(
                f"resume: rebuilding {args.resume}'s replay buffer from "
                f"{packed.FOLDER}/ (re-simulated, checked against its digest)",
                file=sys.stderr,
            )
            ckpt = packed.unpack(args.resume, files=packed_files)
            del packed_files  # the chunks' arrays: tens of MB for the whole run
        trainer = Trainer(cfg, out, command=_command_line(args.argv))
        try:
            trainer.load_state_dict(ckpt)
        except (KeyError, RuntimeError, ValueError, TypeError) as e:
            # e.g. networks of other sizes
            if isinstance(e, CheckpointError):
                raise
            first = (str(e).strip().splitlines() or [type(e).__name__])[0][:160]
            raise CheckpointError(
                f"checkpoint {ckpt_path!r} does not fit the run it names "
                f"({type(e).__name__}: {first}); "
                "allowed: a checkpoint.pt written by train (or its packed folder)"
            ) from None
        trainer.done = trainer.done and trainer.cycle >= cfg.epochs * cfg.cycles
    else:
        if not args.out:
            raise UsageError("train: --out DIR is required (or --resume DIR)")
        if os.path.exists(os.path.join(args.out, "checkpoint.pt")):
            raise UsageError(
                f"train: --out {args.out!r} already holds a run; "
                "allowed: a new folder, "
                f"or --resume {args.out} to continue it"
            )
        if os.path.exists(os.path.join(args.out, "progress.csv")):
            raise UsageError(
                f"train: --out {args.out!r} holds the progress.csv of a run with no "
                "checkpoint to continue from (killed in its first epoch?); allowed: "
                "a new folder, or remove its progress.csv to start the run again"
            )
        kept = [
            f
            for f in ("policy.pt", "done.json")
            if os.path.exists(os.path.join(args.out, f))
        ]
        if kept:  # a finished run's policy, or an exported one: not ours to overwrite
            raise UsageError(
                f"train: --out {args.out!r} holds {' and '.join(kept)} (a trained "
                "policy) without a checkpoint to continue from; allowed: a new folder"
            )
        _check_run_file_kinds(args.out, "--out")
        from acder_lite.runs.read import run_folder_above

        above = run_folder_above(args.out)
        if above:  # table, pack and sweep would find it as a run of its own in that one
            raise UsageError(
                f"train: --out {args.out!r} is inside the run folder {str(above[0])!r} "
                f"(it holds {above[1]}); allowed: a folder outside every run folder"
            )
        cfg = Config(**given)
        cfg.resolve()  # the one-line error of a bad option, before a folder is made
        made = not os.path.exists(args.out)
        _make_run_folder(args.out)
        out = args.out
        try:
            trainer = Trainer(cfg, out, command=_command_line(args.argv))
        except BaseException:
            # e.g. out of memory for the buffer, or Ctrl-C: leave no empty folder
            if made and not os.listdir(out):
                os.rmdir(out)
            raise
        note = ""
    from acder_lite.precision import threads_warning, warning_if_slow

    slow = warning_if_slow(trainer.cfg.update_dtype)
    for warning in (note, slow, threads_warning(trainer.cfg.threads)):
        if warning:
            print(warning, file=sys.stderr)
    from acder_lite.signals import interrupt_on_signals

    interrupt_on_signals()
    try:
        rows = trainer.train(progress=not args.quiet)
    except KeyboardInterrupt:
        if os.path.exists(os.path.join(out, "checkpoint.pt")) or packed.has_packed(out):
            print(
                f"interrupted: the last checkpoint is in {out}; continue with "
                f"`python -m acder_lite train --resume {out}`",
                file=sys.stderr,
            )
        else:  # a new run stopped in its first epoch: nothing to resume from
            gone = _drop_unsaved_run(out)
            print(
                f"interrupted before the first checkpoint: nothing in {out} to resume "
                f"(removed its {', '.join(gone) or 'nothing'}); start it again with "
                "the same command",
                file=sys.stderr,
            )
        return 130
    except WriteError as e:  # a full disk, a read-only or removed folder
        line = write_failed(out, trainer, e, resumed=bool(args.resume))
        print(f"error: {line}", file=sys.stderr)
        return 2
    last = rows[-1] if rows else {}
    print(
        f"done: {out} epochs={trainer.cycle / cfg.cycles:g} "
        f"episodes={trainer.episodes} "
        f"test_success={last.get('test_success', float('nan')):.3f}"
    )
    return 0


def _check_resume_folder(run: str) -> None:
    """--resume takes a run folder: a file (its policy.pt, checkpoint.pt) or a path
    that is not there is refused in one line."""
    if os.path.isfile(run):
        raise UsageError(
            f"train: --resume {run!r} is a file; allowed: the run folder "
            f"({os.path.dirname(run) or '.'!r}, where train wrote it)"
        )
    if not os.path.exists(run):
        raise UsageError(
            f"train: --resume {run!r} does not exist; allowed: the folder of a run "
            "train has saved a checkpoint in"
        )


_STOP_FIELDS = ("epochs", "success_threshold", "stop_patience", "stop_gap_episodes")
"""The resumable fields that decide when a run ends."""


def _resume_budget(run: str, ckpt: dict, cfg: Config) -> str | None:
    """Check a resume's --epochs against how far the run has trained (ConfigError: a
    budget below it once silently ended the run there), and say when the run has ended
    (done.json) and this resume would train nothing: the line to print (else None).

    A run that ended on its budget trains on with a larger --epochs; one that stopped
    early (its checkpoint says done) trains on once an option of its stop rule or its
    budget changes (`Trainer.train` then stops by the new rule)."""
    import math
    from pathlib import Path

    from acder_lite.runs.read import RunError, read_json

    old = Config.from_dict(dict(ckpt["config"]))
    progress = ckpt["progress"]
    cycle = progress["cycle"]
    trained = cycle / cfg.cycles
    least = math.ceil(trained - 1e-9)
    if cfg.epochs * cfg.cycles < cycle:
        raise ConfigError(
            f"train: --epochs {cfg.epochs} is not allowed: {run} has trained "
            f"{trained:g} {plural(trained, 'epoch')}; allowed: --epochs >= {least}"
        )
    done_path = os.path.join(run, "done.json")
    if not os.path.isfile(done_path):
        return None  # not ended (or killed before done.json: train writes it)
    changed = any(getattr(cfg, k) != getattr(old, k) for k in _STOP_FIELDS)
    early = bool(progress.get("done")) and cycle < old.epochs * old.cycles
    if cycle < cfg.epochs * cfg.cycles and (not early or changed):
        return None  # extended: trains on
    try:
        reason = read_json(Path(done_path), "done.json").get("stop_reason")
    except RunError:  # the checkpoint's reason, below
        reason = None
    reason = (
        reason
        or progress.get("stop_reason")
        or ("stopped early" if early else "budget")
    )
    longer = f"--epochs N with N > {trained:g}"
    further = f"--resume {run} " + (
        "with a stop rule it has not met (e.g. --stop-patience 0 "
        "--stop-gap-episodes 0: none)"
        + (f" and {longer}" if cycle >= cfg.epochs * cfg.cycles else "")
        if early
        else longer
    )
    return (
        f"train: {run} has already ended ({reason}, epoch {trained:g}); nothing to "
        f"do; to train it further: {further}"
    )


def _drop_unsaved_run(out: str) -> list[str]:
    """Remove the run files a new run wrote before its first checkpoint (config.json;
    progress.csv waits for the checkpoint), so the folder can be started again with the
    same command; a sweep then sees the cell as new, not as one it cannot resume.
    Returns what it removed; a file it cannot remove (a read-only folder) stays: a
    config.json alone does not keep `--out` from starting the run again."""
    from acder_lite.io import RUN_FILES

    gone = []
    for name in RUN_FILES:
        path = os.path.join(out, name)
        if os.path.isfile(path):
            try:
                os.remove(path)
            except OSError:
                continue
            gone.append(name)
    return gone


_NO_ROOM = (errno.ENOSPC, errno.EDQUOT, errno.EFBIG)
_READ_ONLY = (errno.EROFS, errno.EACCES, errno.EPERM)


def write_failed(out: str, trainer, e: WriteError, resumed: bool = False) -> str:
    """The one line of a run whose file `e` could not be written (`io.WriteError`: the
    file's previous version is whole, no temporary file left): what happened, what of
    the run is kept, and the command that goes on once the cause is gone.

    Trap: a full disk at the first epoch's checkpoint ended in a 40-line traceback,
    and the folder held progress.csv without a checkpoint, which both `--resume` and
    the same `--out` refused until the user deleted files by hand. progress.csv now
    waits for the first checkpoint, and a run with none drops its config.json, as an
    interrupted one does (`_drop_unsaved_run`)."""
    from acder_lite.runs import packed

    name = os.path.basename(e.filename or "") or "a file"
    if not os.path.isdir(out):
        again = (
            f"with --out {out} and the options of its first command"
            if resumed
            else "with the same command"
        )
        return (
            f"train: the run folder {out!r} was removed while the run trained "
            f"({name} could not be written); nothing of it is left to resume; start "
            f"it again {again}"
        )
    at = trainer.files.checkpoint_cycle
    fix = (
        "there is space"
        if e.errno in _NO_ROOM
        else "the folder is writable"
        if e.errno in _READ_ONLY
        else "that is fixed"
    )
    what = f"{name} could not be written in {out} ({e.strerror})"
    if at is not None or packed.has_packed(out):
        epoch = f" (epoch {at / trainer.cfg.cycles:g})" if at is not None else ""
        return (
            f"train: {what}; the run is kept at its last checkpoint{epoch}, whole; "
            f"once {fix}, continue with `python -m acder_lite train --resume {out}`"
        )
    gone = _drop_unsaved_run(out)
    return (
        f"train: {what}, and the run has no checkpoint yet; nothing to resume"
        + (f" (removed its {', '.join(gone)})" if gone else "")
        + f"; once {fix}, start it again with the same command"
    )


_TOO_LARGE = (
    "storage size calculation overflowed",  # torch: a tensor past int64 bytes
    "array is too big",  # numpy: an array past the address space
    "maximum allowed dimension exceeded",
)
"""What torch and numpy say (lower case) of a size no memory holds."""


def out_of_memory(e: BaseException) -> bool:
    """numpy's MemoryError, or torch's or MuJoCo's allocator failing (a RuntimeError,
    or MuJoCo's ValueError or FatalError, whose text says it could not allocate
    memory), or a size past what they can count (`_TOO_LARGE`)."""
    text = str(e).lower()
    mujoco_fatal = type(e).__name__ == "FatalError"  # not imported for its class
    return isinstance(e, MemoryError) or (
        (isinstance(e, (RuntimeError, ValueError)) or mujoco_fatal)
        and (
            ("allocate" in text and "memory" in text)
            or any(t in text for t in _TOO_LARGE)
        )
    )


def _make_run_folder(out: str) -> None:
    """Create the run folder `out` (and its parents), or raise UsageError in one line:
    a file in the way, no permission, ..."""
    from acder_lite.io import file_in_the_way

    p = file_in_the_way(out)
    if p:
        raise UsageError(
            f"train: --out {out!r}: {p!r} is a file; "
            "allowed: a folder (or a path not yet there)"
        )
    try:
        os.makedirs(out, exist_ok=True)
        probe_write(out)
    except OSError as e:
        raise UsageError(
            f"train: --out {out!r} cannot be made or written ({e.strerror}); "
            "allowed: a folder you can write to"
        ) from None


def _check_run_json(run: str) -> None:
    """A resumed run keeps its config.json's first command and adds its own
    (`RunFiles.write_config`): one it cannot read is refused before anything is
    trained or rewritten."""
    import json

    path = os.path.join(run, "config.json")
    if not os.path.exists(path):
        return  # written anew
    if not os.path.isfile(path):
        raise CheckpointError(
            f"run folder {run!r}: its config.json is not a file; allowed: the "
            "config.json train wrote (or none, to have it written anew)"
        )
    try:
        with open(path, encoding="utf-8") as f:
            d = json.load(f)
    except (OSError, UnicodeDecodeError, ValueError) as e:
        raise CheckpointError(
            f"run folder {run!r}: its config.json cannot be read "
            f"({type(e).__name__}); allowed: the config.json train wrote "
            "(fix it, or move it away to have it written anew)"
        ) from None
    if not isinstance(d, dict):
        raise CheckpointError(
            f"run folder {run!r}: its config.json holds a {type(d).__name__}, not a "
            "JSON object; allowed: the config.json train wrote (fix it, or move it "
            "away to have it written anew)"
        )
    if not isinstance(d.get("resumes", []), list):
        raise CheckpointError(
            f'run folder {run!r}: its config.json\'s "resumes" is a '
            f"{type(d['resumes']).__name__}, not a list; allowed: the config.json "
            "train wrote (fix it, or move it away to have it written anew)"
        )


def _check_run_file_kinds(run: str, option: str) -> None:
    """A run's file that is there as a folder (or a pipe, ...) is refused before
    anything is trained. Trap: the atomic rename onto it failed only where train
    writes it (an epoch's end, the run's end), a traceback after the work.
    checkpoint.pt has its own lines (`load_torch`, "already holds a run")."""
    from acder_lite.io import RUN_FILES

    for name in RUN_FILES:
        path = os.path.join(run, name)
        if (
            name != "checkpoint.pt"
            and os.path.exists(path)
            and not os.path.isfile(path)
        ):
            raise UsageError(
                f"train: {option} {run!r}: its {name} is not a file; allowed: the "
                f"{name} train writes there, or none (move it away)"
            )


MAX_EVAL_EPISODES = 10_000
"""The most episodes `eval` runs: a thousand times its default, about 20 minutes of
Push here. Trap: a huge --episodes ran for ever."""


def cmd_eval(args) -> int:
    import numpy as np

    from acder_lite.envs import fetch as E
    from acder_lite.io import load_torch
    from acder_lite.train.rollout import Policy, run_episodes

    if not 1 <= args.episodes <= MAX_EVAL_EPISODES:
        raise UsageError(
            f"eval: --episodes {args.episodes} is not allowed: an integer in "
            f"[1, {MAX_EVAL_EPISODES}]"
        )
    if args.seed < 0:
        raise UsageError(f"eval: --seed {args.seed} is not allowed: an integer >= 0")
    if args.env == "":  # it was read as no --env: the checkpoint's
        raise UsageError(
            "eval: --env '' is empty; allowed: the checkpoint's task, or no --env"
        )
    # runs nothing from the file; checks the policy's keys and shapes
    ckpt = load_torch(args.checkpoint)
    pol = ckpt["policy"]
    env_id = args.env or pol["env"]
    if env_id != pol["env"]:
        raise CheckpointError(
            f"checkpoint {args.checkpoint!r} was trained on {pol['env']}, "
            f"not {env_id}; "
            f"allowed: --env {pol['env']}"
        )
    if env_id not in E.ENV_IDS:
        raise CheckpointError(
            f"checkpoint {args.checkpoint!r} names env {env_id!r}; allowed: one of "
            f"{', '.join(E.ENV_IDS)}"
        )
    policy = Policy.from_state_dict(pol)
    from acder_lite.envs.fetch import policy_env

    env = policy_env(pol, args.checkpoint, seed=args.seed)  # the set it was trained on
    T = E.horizon(env_id)
    succ = [run_episodes([env], policy, T)["success"][0] for _ in range(args.episodes)]
    print(
        f"eval: env={env_id} method={pol['method']} episodes={args.episodes} "
        f"success_rate={float(np.mean(succ)):.3f}"
    )
    return 0


def cmd_bench(args) -> int:
    from acder_lite.cli.bench import run_bench

    return run_bench(args)


def core_parser(description: str = "") -> tuple[argparse.ArgumentParser, object]:
    """The parser of `python -m acder_lite` with its own commands (train, eval, bench)
    and the subparsers object, to which `cli.main.build_parser` adds the commands of
    the layers below (pack, table, robust, export, diagnose, sweep)."""
    p = _Parser(
        prog="python -m acder_lite",
        description=description,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    sub = p.add_subparsers(
        dest="cmd", parser_class=_Parser, required=True, metavar="COMMAND"
    )

    t = sub.add_parser("train", help=COMMANDS["train"], description=COMMANDS["train"])
    add_config_options(t)
    t.add_argument(
        "--out", help="run folder: progress.csv, config.json, checkpoint.pt, policy.pt"
    )
    t.add_argument(
        "--resume",
        metavar="DIR",
        help="continue the run in DIR from its last checkpoint, which is the run's "
        "record: progress.csv is rewritten from the checkpoint's rows (rows logged "
        "after it are dropped, as the same numbers come again)",
    )
    t.add_argument("--quiet", action="store_true", help="no progress bar")
    t.set_defaults(func=cmd_train)

    e = sub.add_parser("eval", help=COMMANDS["eval"], description=COMMANDS["eval"])
    e.add_argument("--checkpoint", required=True, help="checkpoint.pt or policy.pt")
    e.add_argument(
        "--episodes",
        type=int,
        default=10,
        help="deterministic test episodes to run, at most "
        f"{MAX_EVAL_EPISODES} (default: 10)",
    )
    e.add_argument(
        "--env",
        default=None,
        help="must match the checkpoint's env (default: the checkpoint's)",
    )
    e.add_argument(
        "--seed",
        type=int,
        default=12345,
        help="seed of the test episodes' goals and starts, an integer >= 0 "
        "(default: 12345)",
    )
    e.set_defaults(func=cmd_eval)

    b = sub.add_parser("bench", help=COMMANDS["bench"], description=COMMANDS["bench"])
    b.add_argument("--env", default="FetchPush-v4")
    b.add_argument("--method", default="her")
    b.add_argument("--workers", type=int, default=4)
    from acder_lite.cli.bench import MAX_CYCLES

    b.add_argument(
        "--cycles",
        type=int,
        default=6,
        help=f"timed cycles after one warm-up cycle, at most {MAX_CYCLES} "
        "(that many of each precision with --update-dtype both)",
    )
    b.add_argument(
        "--threads",
        type=int,
        default=2,
        help=f"CPU threads, as train's --threads: at most {MAX_THREADS} (default: 2)",
    )
    b.add_argument(
        "--update-dtype",
        default="auto",
        choices=["auto", "float32", "bfloat16", "both"],
        help="precision of the gradient step (auto: as train picks it on this CPU); "
        "'both' times the two in one run, with their ratio",
    )
    b.add_argument(
        "--device",
        default="auto",
        choices=["auto", "cpu", "cuda"],
        help="where the networks and the update run (auto: CUDA if any)",
    )
    b.add_argument(
        "--compile-update",
        action="store_true",
        help="the update's losses under torch.compile (Config.compile_update; "
        "compiled in the warm-up cycle)",
    )
    b.set_defaults(func=cmd_bench)
    return p, sub


def base_parser() -> argparse.ArgumentParser:
    """`core_parser` alone: what a sweep's cell parses its train command with."""
    return core_parser()[0]


_SIZES = {
    "train": "buffer_size, hidden, layers, batch_size, workers, pool_size",
    "bench": "--workers",
    "sweep": "buffer_size, hidden, layers, batch_size, workers, pool_size",
    "eval": "--episodes",
    "table": "--resamples",
    "diagnose": "--batches, --episodes",
    "robust": "--trials",
}
"""What a command's out-of-memory line names as the sizes to make smaller."""


def run_main(make_parser, argv: list[str] | None = None) -> int:
    """Parse `argv` with `make_parser()` and run its command: the exit code, with bad
    input as one line and code 2, never a traceback (`cli.main.main`)."""
    args = None
    try:
        args = make_parser().parse_args(argv)
        args.argv = argv
        return int(args.func(args) or 0)
    except (UsageError, ConfigError, CheckpointError, WriteError) as e:
        # WriteError: an output a command could not write (a full disk, a read-only
        # folder), where the command has no line of its own for it
        print(f"error: {e}", file=sys.stderr)
        return 2
    except PermissionError as e:  # a file or folder of the input this user cannot read
        where = f" {e.filename!r}" if e.filename else ""
        print(
            f"error: permission denied{where} ({e.strerror or e}); allowed: files and "
            "folders this user can read (and write, for outputs)",
            file=sys.stderr,
        )
        return 2
    except KeyboardInterrupt:
        print("interrupted", file=sys.stderr)
        return 130
    except BrokenPipeError:
        # the reader went away (`table | head`): stop quietly, and keep Python's own
        # flush at exit from failing again on the closed pipe
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        return 141
    except Exception as e:
        if not out_of_memory(e):
            raise
        first = (str(e).strip().splitlines() or [type(e).__name__])[0][:200]
        sizes = _SIZES.get(getattr(args, "cmd", None), _SIZES["train"])
        print(
            f"error: out of memory ({first}); allowed: sizes this machine can hold "
            f"({sizes})",
            file=sys.stderr,
        )
        return 2
