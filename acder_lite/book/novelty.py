"""Familiar against unseen transitions: what S-ICM's error tells apart (chapter 4)

Chapter 4 reads S-ICM's prediction error 1/2 ||F(s, a) - s'||^2 (Eq. 4 before the clip)
on four kinds of transitions, for a model trained on each S-ICM input: the trainer's
own buffer (familiar), fresh exploration, and scripted excursions that drive the
gripper where the buffer has never been. `episode_errors` takes the error of every step
of whole episodes, `error_sets` of all four kinds per input, `medians` and `shares_at`
(the share of errors at or above a clip eta) read them; `clip_shares` keeps the shares
of familiar and new transitions at the paper's two eta values, which `clip_table`
lays out. The sentences the chapter glues say what the numbers show: `scale_words` the
span of the medians, `novelty_contrast` familiar against fresh and scripted,
`clip_effect` and `clip_readings` what each clip does to an input's errors by the
start-state rule's criterion, and `eta_verdict` whether both of the paper's values keep
the novelty gap. Around them: `loss_path` says where each model's training loss went,
`ratio_table` lays the medians out over the familiar one, and `rollout_halves` reads
one rollout's errors while it explores and while it sweeps away. Nothing is trained:
the models only predict.

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
    `error_sets`: familiar, then the episodes'), as `novelty_contrast` takes them."""
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


def scale_words(medians: dict[str, list[float]], default: str) -> str:
    """The span of each input's medians, "A to B on raw inputs (the default) and C to
    D on normalised inputs", `default` being the package's S-ICM input
    (`Config.sicm_input`)."""
    scale = [
        f"{min(m):.2g} to {max(m):.2g} on {inp} inputs"
        + (" (the default)" if inp == default else "")
        for inp, m in medians.items()
    ]
    return " and ".join(scale)


def clip_shares(
    sets: dict[str, dict[str, np.ndarray]], etas=(0.05, 0.8)
) -> dict[tuple[str, str, float], float]:
    """The shares of familiar (`FAMILIAR`, "fam") and of new (`NEW`, "new")
    transitions at or above each clip of `etas` (the paper's two by default), keyed
    (input, "fam" or "new", eta): what `clip_table`, `clip_readings` and
    `novelty_contrast`'s `at_clip` read."""
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
    significant digits, as `novelty_contrast` words them."""
    inputs = list(dict.fromkeys(inp for inp, _, _ in sat))
    etas = list(dict.fromkeys(x for _, _, x in sat))
    cols = [(x, k) for x in etas for k in ("familiar", "new")]
    head = ["share at the clip"] + [f"{k}, eta = {x}" for x, k in cols]
    rows = [[inp] + [percent(sat[inp, k[:3], x], 2) for x, k in cols] for inp in inputs]
    return head, rows


def novelty_contrast(
    medians: dict[str, list[float]],
    at_clip: dict[str, tuple[float, float]],
    eta: float,
) -> dict[str, str]:
    """Chapter 4's familiar-against-unseen comparison in words, from the numbers.

    `medians`: per S-ICM input, the median errors of the familiar transitions, of
    fresh exploration, then of one or more scripted excursions, in that order.
    `at_clip`: per input, the shares of familiar and of new transitions at or above
    the clip `eta`. Returns sentences (Markdown, no maths):

    - `scripted`: whether the scripted excursions are predicted worse than both the
      familiar transitions and fresh exploration, and their medians over the
      familiar one;
    - `new`: fresh exploration's median over the familiar one, and whether it comes
      closer to it than every scripted excursion;
    - `tail`: per input, which of familiar and new transitions reach the clip more
      often (no leading capital: the chapter writes "At eta = ..., " before it);
    - `summary`: the three in one sentence, without a capital or a full stop.
    """
    if not medians or any(len(m) < 3 for m in medians.values()):
        raise ValueError(
            "novelty_contrast: each input needs the medians of familiar, new and at "
            "least one scripted set"
        )

    r = {i: np.asarray(m, np.float64) / m[0] for i, m in medians.items()}
    scripted, short = _scripted_sentence(medians, r)
    closer = all(v[1] < min(v[2:]) for v in r.values())
    how = "comes closer" if closer else "does not come closer"
    than = "any" if closer else "every"
    new = (
        f"Fresh exploration {how} to the familiar transitions than {than} scripted "
        "excursion: its median error is "
        + _on_each([(f"{v[1]:.2g} times", i) for i, v in r.items()])
        + "."
    )
    tail = _clip_tail(at_clip)
    summary = (
        f"{short} {_WORSE}; fresh exploration's median error is "
        f"{_times([v[1] for v in r.values()])} the familiar one; and at η = {eta:g}, "
        f"{tail}"
    )
    return dict(scripted=scripted, new=new, tail=tail, summary=summary)


_WORSE = "predicted worse than both the familiar transitions and fresh exploration"


def _times(v) -> str:
    """Ratios as "3.1 times" or "2.5 to 4 times"."""
    lo, hi = f"{min(v):.2g}", f"{max(v):.2g}"
    return f"{lo} times" if lo == hi else f"{lo} to {hi} times"


def _on_each(parts: list[tuple[str, str]]) -> str:
    """(text, input) pairs as "T1 the familiar one on raw inputs and T2 on ... ones"."""
    said = [f"{parts[0][0]} the familiar one on {parts[0][1]} inputs"]
    return " and ".join(said + [f"{t} on {i} ones" for t, i in parts[1:]])


def _scripted_sentence(medians: dict, r: dict) -> tuple[str, str]:
    """`novelty_contrast`'s `scripted` sentence, and its short form for the summary."""
    over = [i for i, m in medians.items() if min(m[2:]) > max(m[:2])]
    where = "the scripted excursions, which go where the buffer has never been,"
    if len(over) == len(r):
        on = "on both inputs" if len(r) == 2 else "on all inputs"
        lead, short = f"{on} {where} are {_WORSE}", f"{on} the scripted excursions are"
    else:
        on = f"only on {' and '.join(over)} inputs" if over else "on no input"
        lead, short = f"{on} are {where} {_WORSE}", f"{on} are the scripted excursions"
    scripted = (
        f"{lead[0].upper()}{lead[1:]}: their median errors are "
        + _on_each([(_times(v[2:]), i) for i, v in r.items()])
        + "."
    )
    return scripted, short


def _clip_tail(at_clip: dict[str, tuple[float, float]]) -> str:
    """`novelty_contrast`'s `tail`: per input, which of familiar and new transitions
    reach the clip more often."""
    parts = []
    for i, (f, n) in at_clip.items():
        if f == n == 0:
            parts.append(f"neither familiar nor new transitions reach it on {i} inputs")
        elif f != n:
            a, b, x, y = (
                ("familiar", "new", f, n) if f > n else ("new", "familiar", n, f)
            )
            parts.append(
                f"{a} transitions reach it more often than {b} ones on {i} inputs "
                f"({percent(x, 2)} against {percent(y, 2)})"
            )
        else:
            parts.append(
                f"familiar and new transitions reach it equally often on {i} inputs "
                f"({percent(f, 2)})"
            )
    parts[0] = parts[0].replace("reach it", "reach the clip", 1)
    return ", while ".join(parts)


def clip_effect(familiar: float, new: float, name: str) -> tuple[str, bool]:
    """What a clip eta does to one S-ICM input's errors, in words (chapter 4), from
    the shares of familiar and of new transitions at or above it: (sentence, whether
    it keeps the novelty gap).

    The criterion is the start-state rule's, the one chapter 8 ("What S-ICM sees") and
    book/departures.md (departure 6) apply to the paper's eta values: the rule ranks
    the rows of successful episodes by their *clipped* r^i (Eq. 4), and the paper uses
    the clip "to keep novelty gap between states". Every error at or above eta earns
    the same r^i = eta, so a clip keeps that gap, i.e. still ranks states by novelty,
    only where most errors fall below it:

    - no error reaches it: it ranks every state and only bounds outliers not seen in
      these errors (True);
    - most of both sets fall below it, some reach it: it ranks the ones below and caps
      the rest (True);
    - most of either set reach it (a share above a half): curiosity is a flat bonus
      there, and the "most novel" state a tie between rows at eta (False).
    """
    most = [k for k, v in (("familiar", familiar), ("new", new)) if v > 0.5]
    if len(most) == 2:
        return (
            f"most {name} errors sit at the clip, making curiosity a flat bonus that "
            "ranks none of them",
            False,
        )
    if most:
        return (
            f"most of the {most[0]} {name} errors sit at the clip, where they tie",
            False,
        )
    if max(familiar, new) == 0:
        return (
            f"no {name} error here reaches it, so it ranks every state and only bounds "
            "outliers not seen here",
            True,
        )
    return (
        f"most {name} errors fall below it, which it ranks, and it caps the part "
        "that reaches it",
        True,
    )


def clip_readings(
    sat: dict[tuple[str, str, float], float],
) -> tuple[dict[float, str], dict[str, bool]]:
    """`clip_effect` of every input at every eta of `clip_shares`: (per eta, the inputs'
    sentences joined by ", while "; per input, whether every eta keeps its novelty
    gap)."""
    inputs = list(dict.fromkeys(inp for inp, _, _ in sat))
    readings, keeps = {}, {inp: True for inp in inputs}
    for x in dict.fromkeys(x for _, _, x in sat):
        said = [
            clip_effect(sat[inp, "fam", x], sat[inp, "new", x], inp) for inp in inputs
        ]
        readings[x] = ", while ".join(s for s, _ in said)
        keeps = {inp: keeps[inp] and ok for inp, (_, ok) in zip(inputs, said)}
    return readings, keeps


def eta_verdict(keeps: dict[str, bool]) -> str:
    """Whether both of the paper's eta values keep the novelty gap, in one sentence
    (no full stop), from `clip_readings`' `keeps` of the two S-ICM inputs: on either
    input, only on the first that does, or on neither."""
    good = [inp for inp, ok in keeps.items() if ok]
    if len(good) == len(keeps):
        return "Both of the paper's values keep the novelty gap on either input"
    if good:
        return (
            f"Both of the paper's values keep the novelty gap only on {good[0]} inputs"
        )
    return "On neither input do both of the paper's values keep the novelty gap"


def loss_path(rows: dict[str, list[dict]]) -> str:
    """Where each S-ICM input's training loss went, in words: "0.52 to 0.21 on
    normalised and ...", from the first to the last row of `rows` (per input, the
    rows `Trainer.train` returned, each with its `curiosity_loss`)."""
    ends = {
        i: (r[0]["curiosity_loss"], r[-1]["curiosity_loss"]) for i, r in rows.items()
    }
    return " and ".join(f"{a:.3g} to {b:.3g} on {i}" for i, (a, b) in ends.items())


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
