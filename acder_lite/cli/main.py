"""`python -m acder_lite COMMAND`: train, evaluate, time, sweep and export ACDER and
its baselines on the Fetch tasks; `python -m acder_lite COMMAND --help` for one.

Bad input exits with code 2 and one line naming the field and what is allowed; no
traceback.
"""

from __future__ import annotations

import argparse

from acder_lite.cli.train import (  # noqa: F401  (the names tests and users import from here)
    COMMANDS,
    UsageError,
    out_of_memory,
    base_parser,
    cmd_train,
    core_parser,
    given_options,
    run_main,
)


def build_parser() -> argparse.ArgumentParser:
    """Every command's parser: train, eval and bench (`cli.train`), then sweep, pack,
    table, diagnose, robust and export, each from its own module."""
    p, sub = core_parser(description=__doc__.replace("`", ""))
    from acder_lite.cli import diagnose, sweep
    from acder_lite.deploy import export, robust
    from acder_lite.runs import packed, table

    for name, mod in (
        ("sweep", sweep),
        ("pack", packed),
        ("table", table),
        ("diagnose", diagnose),
        ("robust", robust),
        ("export", export),
    ):
        s = sub.add_parser(
            name,
            help=COMMANDS[name],
            description=mod.__doc__.strip().split("\n\n")[0],  # its first paragraph
        )
        mod.add_arguments(s)
        s.set_defaults(func=mod.run)
    return p


def main(argv: list[str] | None = None) -> int:
    """`python -m acder_lite ARGS`: the exit code (`cli.train.run_main`)."""
    return run_main(build_parser, argv)
