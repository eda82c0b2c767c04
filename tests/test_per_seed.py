"""One seed's reading for chapter 7 (acder_lite.book.per_seed): each seed's first
crossing
of the threshold, and how the live runs ended."""


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
    from acder_lite.book.per_seed import crossing_text

    assert [crossing_text(s) for s in out] == [
        "seed 0: not reached (best 0.30 in 800)",
        "seed 1: 800",
    ]


def test_live_ended_names_the_runs_that_stopped_and_a_stop_rule_that_could_not():
    from acder_lite.book.per_seed import live_ended

    both = {"acder": (40, None), "her": (36, None)}
    assert live_ended(both, 5, 5) == "both ran the full 40 episodes"
    assert live_ended(both, 4, 5) == (
        "both ran the full 40 episodes (each run's 4 evaluations: the stop rule"
        " needs 5)"
    )
    ends = {"acder": (24, "success held"), "her": (40, "budget")}
    assert live_ended(ends, 12, 5) == (
        "acder stopped early, after 24 episodes (success held); her stopped early,"
        " after 40 episodes (budget)"
    )
