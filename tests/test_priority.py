"""Prioritised replay (PER) and energy-based prioritisation (EBP):
acder_lite/algo/priority.py."""

import numpy as np
import pytest

from acder_lite.algo.priority import (
    EnergyPrioritizer,
    PrioritizedReplay,
    SumTree,
    per_beta,
    trajectory_energy,
)

# Chi-square critical values at the 0.999 quantile (standard tables),
# by degrees of freedom.
CHI2_999 = {3: 16.266, 4: 18.467, 7: 24.322}


def chi2(counts, probs):
    expected = np.asarray(probs) * np.sum(counts)
    return float(np.sum((np.asarray(counts) - expected) ** 2 / expected))


def test_sumtree_total_and_find_match_cumsum():
    rng = np.random.default_rng(0)
    for cap in (1, 5, 8, 1000):
        p = rng.random(cap) * (rng.random(cap) > 0.3)  # some zero leaves
        p[0] = max(p[0], 0.1)
        tree = SumTree(cap)
        tree.update(np.arange(cap), p)
        assert tree.total() == pytest.approx(p.sum())
        v = rng.random(2000) * p.sum()
        ref = np.searchsorted(np.cumsum(p), v, side="right")
        np.testing.assert_array_equal(tree.find(v), ref)
        assert np.all(p[tree.find(v)] > 0)
        assert np.all(
            p[tree.find(np.array([0.0, p.sum(), 2 * p.sum()]))] > 0
        )  # edges clipped


def test_sumtree_repeated_index_last_write_wins():
    tree = SumTree(6)
    tree.update(np.arange(6), np.ones(6))
    tree.update(np.array([3, 1, 3, 3, 1]), np.array([7.0, 2.0, 9.0, 5.0, 4.0]))
    np.testing.assert_array_equal(tree.leaves(), [1, 4, 1, 5, 1, 1])
    assert tree.total() == 13.0


def test_sumtree_samples_proportionally_and_state_dict():
    p = np.arange(1, 9, dtype=float)  # 8 leaves: 7 degrees of freedom
    tree = SumTree(8)
    tree.update(np.arange(8), p)
    rng = np.random.default_rng(1)
    leaf = tree.find(rng.random(40000) * tree.total())
    assert chi2(np.bincount(leaf, minlength=8), p / p.sum()) < CHI2_999[7]
    t2 = SumTree(8)
    t2.load_state_dict(tree.state_dict())
    np.testing.assert_array_equal(t2.tree, tree.tree)


def test_per_new_episodes_get_max_priority():
    per = PrioritizedReplay(4, T=2, alpha=0.5, eps=0.0)
    per.add_episodes(np.array([0, 1]))
    np.testing.assert_array_equal(per.tree.leaves(), [1, 1, 1, 1, 0, 0, 0, 0])
    assert per.n_transitions == 4
    per.update(np.array([0, 1]), np.array([1, 0]), np.array([9.0, 0.25]))
    np.testing.assert_allclose(per.tree.leaves()[:4], [1, 3, 0.5, 1])
    per.add_episodes(np.array([2]))  # new episode: max raw priority 9 -> 9^0.5 = 3
    np.testing.assert_allclose(per.tree.leaves()[4:6], [3, 3])
    per.add_episodes(np.array([0]))  # an overwritten slot is new too
    np.testing.assert_allclose(per.tree.leaves()[:2], [3, 3])


def test_per_update_changes_sampling():
    per = PrioritizedReplay(2, T=3, alpha=1.0, eps=0.0)
    per.add_episodes(np.array([0, 1]))
    rng = np.random.default_rng(2)
    ep, _, _ = per.sample(rng, 600, beta=0.4)
    assert abs(np.mean(ep == 1) - 0.5) < 0.01  # equal priorities: stratified halves
    per.update(
        np.array([0, 0, 0, 1, 1, 1]),
        np.array([0, 1, 2, 0, 1, 2]),
        np.array([1, 1, 1, 8, 8, 8.0]),
    )
    ep, t, _ = per.sample(rng, 900, beta=0.4)
    assert abs(np.mean(ep == 1) - 8 / 9) < 0.01
    assert set(t.tolist()) == {0, 1, 2}


def test_per_weights_hand_worked():
    # 3 transitions (1 episode, T=3), alpha=0.5, eps=0, |td| = 1, 4, 25
    # -> P^alpha = 1, 2, 5, total 8, P(i) = 1/8, 2/8, 5/8, N = 3.
    # beta = 0.5: w = (3 P)^-0.5 = sqrt(8/3, 4/3, 8/15);
    # / max (transition 0) -> sqrt(1, 1/2, 1/5) = 1, 0.7071, 0.4472.
    # Batch 8 -> 8 segments of width 1 over [0, 8): segment 0 is leaf 0, 1-2 leaf 1,
    # 3-7 leaf 2.
    for norm in ("global", "batch"):
        per = PrioritizedReplay(1, T=3, alpha=0.5, eps=0.0, weight_norm=norm)
        per.add_episodes(np.array([0]))
        per.update(np.zeros(3, int), np.arange(3), np.array([1.0, -4.0, 25.0]))
        ep, t, w = per.sample(np.random.default_rng(3), 8, beta=0.5)
        np.testing.assert_array_equal(ep, 0)
        np.testing.assert_array_equal(t, [0, 1, 1, 2, 2, 2, 2, 2])
        assert w.dtype == np.float32
        np.testing.assert_allclose(
            w, np.sqrt([1, 0.5, 0.5, 0.2, 0.2, 0.2, 0.2, 0.2]), rtol=1e-6
        )
    # Global vs batch: a batch that misses the smallest priority is normalised
    # differently.
    per = PrioritizedReplay(1, T=3, alpha=0.5, eps=0.0, weight_norm="global")
    per.add_episodes(np.array([0]))
    per.update(np.zeros(3, int), np.arange(3), np.array([1.0, 4.0, 25.0]))
    _, t, w = per.sample(
        np.random.default_rng(3), 1, beta=1.0
    )  # one segment: leaf 2 w.p. 5/8
    # beta = 1: w = (3 P)^-1 / (3 * 1/8)^-1 = (1/8) / P(i).
    np.testing.assert_allclose(w, 1 / 8 / (np.array([1, 2, 5])[t] / 8), rtol=1e-6)


def test_per_state_dict_round_trip():
    rng = np.random.default_rng(4)
    per = PrioritizedReplay(5, T=4, alpha=0.6, eps=1e-6)
    per.add_episodes(np.array([0, 1, 2]))
    per.update(rng.integers(0, 3, 10), rng.integers(0, 4, 10), rng.normal(size=10) * 3)
    per2 = PrioritizedReplay(5, T=4)
    per2.load_state_dict(per.state_dict())
    assert (per2.n, per2.max_priority, per2.alpha) == (
        per.n,
        per.max_priority,
        per.alpha,
    )
    np.testing.assert_array_equal(per2.tree.tree, per.tree.tree)
    np.testing.assert_array_equal(per2._min, per._min)
    a = per.sample(np.random.default_rng(5), 32, 0.7)
    b = per2.sample(np.random.default_rng(5), 32, 0.7)
    for x, y in zip(a, b):
        np.testing.assert_array_equal(x, y)


def test_per_beta_schedule():
    assert per_beta(0.0, 0.4) == pytest.approx(0.4)
    assert per_beta(0.5, 0.4) == pytest.approx(0.7)
    assert per_beta(1.0, 0.4) == pytest.approx(1.0)
    assert per_beta(-1.0, 0.4) == pytest.approx(0.4) and per_beta(
        2.0, 0.4
    ) == pytest.approx(1.0)


def test_trajectory_energy_hand_worked():
    # dt = 0.04, g = 9.81, m = 1, T = 3, clip 0.5. E_k = g dz_k + 0.5 |v_k|^2, E_0 = 0,
    # energy = sum_k clip(E_k - E_{k-1}, 0, 0.5).
    # lifted: z = 0, .01, .02, .03 (v = 0.25 m/s, K = 0.03125):
    #         E = 0.12935, 0.22745, 0.32555;
    #         steps 0.12935, 0.0981, 0.0981 -> 0.32555 (no clip binds).
    # resting: all steps 0 -> 0.
    # falling: z = 0, -.02, -.04, -.06 (v = 0.5, K = 0.125):
    #          E = -0.0712, -0.2674, -0.4636;
    #          every step negative -> clipped to 0 -> 0 (unclipped sum would be
    #          -0.4636).
    # pushed fast then stopped: x = 0, .08, .08, .08 (v = 2, K = 2): steps 2, -2, 0
    #          -> min(2, 0.5) + 0 + 0 = 0.5 (with clip 999: 2.0).
    z = lambda zs: np.stack([np.zeros(4), np.zeros(4), zs], axis=1)
    ag = np.stack(
        [
            z(np.array([0, 0.01, 0.02, 0.03])),
            z(np.zeros(4)) + 0.42,
            z(np.array([0, -0.02, -0.04, -0.06])) + 0.42,
            np.stack(
                [np.array([0, 0.08, 0.08, 0.08]), np.zeros(4), np.zeros(4)], axis=1
            ),
        ]
    ).astype(np.float32)
    e = trajectory_energy(ag, dt=0.04, clip_energy=0.5)
    assert e.shape == (4,)
    np.testing.assert_allclose(e, [0.32555, 0, 0, 0.5], atol=1e-6)
    np.testing.assert_allclose(
        trajectory_energy(ag, 0.04, clip_energy=999), [0.32555, 0, 0, 2.0], atol=1e-5
    )
    # weights: potential only for the lift -> 3 * 0.0981;
    # kinetic only -> 0.03125 (first step).
    np.testing.assert_allclose(
        trajectory_energy(ag[:1], 0.04, w_kinetic=0.0), [0.2943], atol=1e-6
    )
    np.testing.assert_allclose(
        trajectory_energy(ag[:1], 0.04, w_potential=0.0), [0.03125], atol=1e-6
    )


def test_energy_prioritizer_samples_proportional_to_energy():
    energy = np.array([0.0, 1.0, 2.0, 3.0, 4.0])
    ebp = EnergyPrioritizer(8, eps=1e-6)
    ebp.add_episodes(np.array([0, 1, 2]), energy[:3])
    ebp.add_episodes(np.array([3, 4]), energy[3:])
    assert ebp.n == 5
    ep = ebp.sample_episodes(np.random.default_rng(6), 50000)
    counts = np.bincount(ep, minlength=8)
    assert (
        counts[0] == 0 and counts[5:].sum() == 0
    )  # zero energy: only eps; unfilled: never
    assert chi2(counts[1:5], energy[1:] / energy.sum()) < CHI2_999[3]
    ebp2 = EnergyPrioritizer(8)
    ebp2.load_state_dict(ebp.state_dict())
    np.testing.assert_array_equal(
        ebp2.sample_episodes(np.random.default_rng(7), 100),
        ebp.sample_episodes(np.random.default_rng(7), 100),
    )
    # All-zero energies: uniform through eps instead of NaN.
    flat = EnergyPrioritizer(4)
    flat.add_episodes(np.arange(4), np.zeros(4))
    np.testing.assert_allclose(flat.probabilities(), 0.25)


def test_energy_prioritizer_reference_options():
    # Their rank option: s = rank - 1
    # (dense rank of [5, 1, 5, 3] = 3, 1, 3, 2 -> 2, 0, 2, 1).
    ebp = EnergyPrioritizer(4, eps=0.0, rank_method="dense")
    ebp.add_episodes(np.arange(4), np.array([5.0, 1.0, 5.0, 3.0]))
    np.testing.assert_allclose(ebp.probabilities(), np.array([2, 0, 2, 1]) / 5)
    ebp = EnergyPrioritizer(4, eps=0.0, rank_method="average")  # ranks 3.5, 1, 3.5, 2
    ebp.add_episodes(np.arange(4), np.array([5.0, 1.0, 5.0, 3.0]))
    np.testing.assert_allclose(ebp.probabilities(), np.array([2.5, 0, 2.5, 1]) / 6)
    # Their temperature: p ~ E^(1/(T + 0.01)).
    ebp = EnergyPrioritizer(2, eps=0.0, temperature=1.0)
    ebp.add_episodes(np.arange(2), np.array([1.0, 4.0]))
    q = 4.0 ** (1 / 1.01)
    np.testing.assert_allclose(ebp.probabilities(), [1 / (1 + q), q / (1 + q)])
