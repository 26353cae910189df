"""The rate tests' early verdict: a rate test stops once its assertion is settled, and never before."""

from __future__ import annotations

import itertools

from terrain_rates import decided, until_decided


def _run(outcomes: list[bool], needed: int | None) -> list[int]:
    ran = []
    for (i, ok), record in until_decided(list(enumerate(outcomes)), needed):
        ran.append(i)
        record(ok)
    return ran


def test_a_rate_stops_once_settled_and_its_verdict_is_that_of_every_run() -> None:
    for n in (3, 4):
        for needed in range(0, n + 1):
            for outcomes in itertools.product([False, True], repeat=n):
                ran = _run(list(outcomes), needed)
                assert ran == list(range(len(ran)))  # in order, a prefix
                passed = sum(outcomes[i] for i in ran)
                assert decided(passed, len(ran), n, needed)  # settled where it stopped
                assert (passed >= needed) == (sum(outcomes) >= needed)  # the same verdict as all runs
                if len(ran) > 0:  # and not settled one run earlier
                    before = sum(outcomes[i] for i in ran[:-1])
                    assert not decided(before, len(ran) - 1, n, needed)


def test_without_a_bound_every_variant_runs() -> None:
    assert _run([False, True, False, False], needed=None) == [0, 1, 2, 3]
