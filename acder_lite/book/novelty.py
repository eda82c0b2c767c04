"""Familiar against unseen transitions: what S-ICM's error tells apart (chapter 4)

Chapter 4 reads S-ICM's prediction error 1/2 ||F(s, a) - s'||^2 (Eq. 4 before the clip)
on four kinds of transitions, for a model trained on each S-ICM input: the trainer's
own buffer (familiar), fresh exploration, and scripted excursions that drive the
gripper where the buffer has never been. `episode_errors` takes the error of every step
of whole episodes, `error_sets` of all four kinds per input, `medians` and `shares_at`
(the share of errors at or above a clip eta) read them; `clip_shares` keeps the shares
of familiar and new transitions at the paper's two eta values, which `clip_table`
lays out, and `keeps_gap` / `gaps_kept` apply the start-state rule's criterion to them.
`ratio_table` lays the medians out over the familiar one, and `rollout_halves` reads
one rollout's errors while it explores and while it sweeps away. Nothing is trained:
the models only predict, and nothing here writes a sentence: the chapter words the
numbers by hand and asserts what it says.

Traps: the error is in the input's own units (squared standard deviations of the buffer
on normalised inputs, squared metres and radians on raw ones), so only ratios compare
across inputs, never levels. The familiar set is the buffer's first episodes as
stored: once the buffer has wrapped around they are no longer its oldest. A share at
the clip counts errors *at or above* eta, all of which earn the same reward eta: a
clip that most errors reach ranks none of them.
"""

from __future__ import annotations

import numpy as np
import torch

from acder_lite.book.utils import percent
from acder_lite.config import ConfigError
from acder_lite.algo.curiosity import SICM

FAMILIAR = "familiar (buffer)"
"""`error_sets`' name of the errors on the trainer's own buffer."""
NEW = "new exploration"
"""The name of fresh exploration among `error_sets`' episodes, as chapter 4 gives it;
`clip_shares` sets it against `FAMILIAR`, as the clip figures do
(`plots.clip_histogram`)."""


def episode_errors(trainer, ep: dict, eta: float = np.inf) -> np.ndarray:
    """Eq. 4 for every step of whole episodes, shape (W, T), without training the model.

    `ep` holds arrays with a leading env axis, as
    `acder_lite.train.rollout.run_episodes` returns them: o (W, T+1, .), g and u (W, T,
    .). The model sees them as the trainer gives them to it (`Trainer.curiosity_inputs`,
    so `Config.sicm_input` decides normalised or raw); `eta=inf` leaves out the clip and
    returns the model's error
    itself."""
    from acder_lite.algo.rewards import intrinsic_reward

    if not isinstance(trainer.curiosity, SICM):
        raise ConfigError(
            f"method={trainer.cfg.method!r} has no S-ICM; "
            "allowed: acder and its ablations"
        )
    W, T = ep["u"].shape[:2]

    def flat(a):
        return np.ascontiguousarray(a).reshape(W * T, -1)

    batch = dict(
        o=flat(ep["o"][:, :-1]),
        o2=flat(ep["o"][:, 1:]),
        g=flat(ep["g"]),
        u=flat(ep["u"]),
    )
    tb = trainer.batch_tensors(batch)
    s, s2 = trainer.curiosity_inputs(batch, tb)
    with torch.no_grad():
        pred = trainer.curiosity(s, tb["u"])
    return intrinsic_reward(pred.cpu().numpy(), s2.cpu().numpy(), eta).reshape(W, T)


def error_sets(
    trainers: dict, episodes: dict[str, dict], familiar: int = 4
) -> dict[str, dict[str, np.ndarray]]:
    """Each trainer's S-ICM errors before the clip (`episode_errors`), per S-ICM input
    (the keys of `trainers`): first `FAMILIAR`, on the first `familiar` episodes of
    the trainer's own buffer, then one array per entry of `episodes` (name -> arrays
    of `rollout.run_episodes`), in its order. Every model sees the same `episodes`,
    each through its own input."""
    sets = {}
    for inp, t in trainers.items():
        keep = ("o", "g", "u")
        own = {k: v[:familiar] for k, v in t.buffer.arrays().items() if k in keep}
        sets[inp] = {FAMILIAR: episode_errors(t, own)}
        sets[inp] |= {name: episode_errors(t, ep) for name, ep in episodes.items()}
    return sets


def medians(sets: dict[str, dict[str, np.ndarray]]) -> dict[str, list[float]]:
    """Per input, the median error of each of its sets, in their order (for
    `error_sets`: familiar, then the episodes')."""
    return {inp: [float(np.median(e)) for e in s.values()] for inp, s in sets.items()}


def shares_at(
    sets: dict[str, dict[str, np.ndarray]], etas, names=None
) -> dict[str, dict[str, np.ndarray]]:
    """Per input and set (only `names`, if given, in their order), the share of errors
    at or above each clip of `etas`: the transitions Eq. 4 pays the full eta."""
    return {
        inp: {
            name: np.array([float(np.mean(s[name] >= x)) for x in etas])
            for name in (s if names is None else names)
        }
        for inp, s in sets.items()
    }


def clip_shares(
    sets: dict[str, dict[str, np.ndarray]], etas=(0.05, 0.8)
) -> dict[tuple[str, str, float], float]:
    """The shares of familiar (`FAMILIAR`, "fam") and of new (`NEW`, "new")
    transitions at or above each clip of `etas` (the paper's two by default), keyed
    (input, "fam" or "new", eta): what `clip_table` and `gaps_kept` read."""
    at = shares_at(sets, etas, names=(FAMILIAR, NEW))
    return {
        (inp, k, x): float(at[inp][name][j])
        for inp in sets
        for k, name in (("fam", FAMILIAR), ("new", NEW))
        for j, x in enumerate(etas)
    }


def clip_table(sat: dict[tuple[str, str, float], float]):
    """`clip_shares` as a table for `table.to_html`: (header, rows), a row per input,
    a column per eta and set (familiar, then new), shares as percentages to two
    significant digits, as the chapter quotes them."""
    inputs = list(dict.fromkeys(inp for inp, _, _ in sat))
    etas = list(dict.fromkeys(x for _, _, x in sat))
    cols = [(x, k) for x in etas for k in ("familiar", "new")]
    head = ["share at the clip"] + [f"{k}, eta = {x}" for x, k in cols]
    rows = [[inp] + [percent(sat[inp, k[:3], x], 2) for x, k in cols] for inp in inputs]
    return head, rows


def keeps_gap(familiar: float, new: float) -> bool:
    """Whether a clip eta keeps the novelty gap on one S-ICM input, from the shares of
    familiar and of new transitions at or above it (`clip_shares`).

    The criterion is the start-state rule's, the one chapter 8 ("What S-ICM sees") and
    book/departures.md (departure 6) apply to the paper's eta values: the rule ranks
    the rows of successful episodes by their *clipped* r^i (Eq. 4), and the paper uses
    the clip "to keep novelty gap between states". Every error at or above eta earns
    the same r^i = eta, so a clip keeps that gap, i.e. still ranks states by novelty,
    only where most errors of both sets fall below it (a share at the clip of at most
    a half). A clip that no error reaches keeps it too: it ranks every state and only
    bounds outliers not seen in these errors."""
    return max(familiar, new) <= 0.5


def gaps_kept(sat: dict[tuple[str, str, float], float]) -> dict[str, bool]:
    """Per S-ICM input of `clip_shares`' `sat`, whether every eta in it keeps the
    novelty gap (`keeps_gap`)."""
    inputs = list(dict.fromkeys(inp for inp, _, _ in sat))
    etas = list(dict.fromkeys(x for _, _, x in sat))
    return {
        inp: all(keeps_gap(sat[inp, "fam", x], sat[inp, "new", x]) for x in etas)
        for inp in inputs
    }


def ratio_table(medians: dict[str, list[float]], names):
    """`medians`' table for `table.to_html`: (header, rows), a row per input, each
    set's median over the familiar one's (the first) to three significant digits, so
    that inputs of other units compare (1: predicted as well as the familiar set);
    `names` are the sets' names, in the medians' order."""
    head = ["median / familiar median"] + list(names)
    rows = [[inp] + [f"{x / m[0]:.3g}" for x in m] for inp, m in medians.items()]
    return head, rows


def rollout_halves(
    errors: dict[str, np.ndarray], etas: dict[str, float], explore: int, turn: int
) -> dict[tuple[str, str], tuple[float, float]]:
    """One rollout's errors (per input, one a step) read in two halves: "explore", its
    first `explore` steps, and "sweep", the steps after those and the `turn` that
    follow them (the sweep without its turn). Returns {(input, half): (median error,
    share of steps at or above the input's clip `etas[input]`)}, per input explore
    first: the share Eq. 4 pays the full eta."""
    out = {}
    for inp, e in errors.items():
        e = np.asarray(e)
        for half, s in (("explore", e[:explore]), ("sweep", e[explore + turn :])):
            out[inp, half] = (float(np.median(s)), float(np.mean(s >= etas[inp])))
    return out
