"""One seed's reading for "Results in detail" (acder_lite.book.per_seed): each
seed's first crossing of the threshold."""


def test_seed_crossings_reads_each_seeds_first_crossing():
    from acder_lite.book.per_seed import seed_crossings

    def run(seed, values, name="her", env="FetchPush-v4"):
        rows = [
            dict(episodes=400.0 * k, test_success=v) for k, v in enumerate(values, 1)
        ]
        return dict(env=env, name=name, seed=seed, rows=rows)

    runs = [
        run(1, [0.2, 0.96, 0.5]),
        run(0, [0.1, 0.3]),
        run(2, [1.0], name="acder"),
        run(3, [1.0], env="FetchReach-v4"),
        dict(env="FetchPush-v4", name="her", seed=4, rows=[]),
    ]
    out = seed_crossings(runs, "FetchPush-v4", "her", 0.95)
    assert [s["seed"] for s in out] == [0, 1]
    assert out[0] == dict(seed=0, hit=None, best=0.3, episodes=800.0)
    assert out[1] == dict(seed=1, hit=800.0, best=0.96, episodes=1200.0)
    assert seed_crossings(runs, "FetchPush-v4", "her-per", 0.95) == []


def test_a_crossing_exactly_at_the_threshold_counts_and_the_first_one_is_kept():
    """At or above: a seed evaluated at exactly 0.95 has crossed there; a later, higher
    evaluation does not move its crossing."""
    from acder_lite.book.per_seed import seed_crossings

    rows = [dict(episodes=40.0 * k, test_success=v) for k, v in [(1, 0.5), (2, 0.95),
            (3, 0.9), (4, 1.0)]]  # fmt: skip
    (s,) = seed_crossings(
        [dict(env="FetchPush-v4", name="acder", seed=0, rows=rows)],
        "FetchPush-v4",
        "acder",
        0.95,
    )
    assert s == dict(seed=0, hit=80.0, best=1.0, episodes=160.0)
