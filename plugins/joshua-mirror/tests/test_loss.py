"""Counting lost messages from publication sequence numbers: gaps, several publishers on a topic, restarts."""

from __future__ import annotations

from joshua_mirror.loss import TopicLoss


def seen(sequences: list[int], publishers: int = 1) -> TopicLoss:
    loss = TopicLoss(lambda: publishers)
    for sequence in sequences:
        loss.see(sequence)
    return loss


def test_consecutive_numbers_lose_nothing_and_gaps_count_exactly() -> None:
    assert seen(list(range(1, 500))).lost == 0
    assert seen([1, 2, 5, 6, 100, 101]).lost == 2 + 93
    assert seen([400, 401, 405]).lost == 3  # a publisher that began before the mirror: its start is no loss


def test_interleaved_publishers_are_told_apart_by_their_numbers() -> None:
    one, two = list(range(1000, 1100)), list(range(1, 100))
    interleaved = [number for pair in zip(one, two, strict=False) for number in pair]
    assert seen(interleaved, publishers=2).lost == 0
    with_gaps = [number for number in interleaved if number not in (1010, 1011, 50)]
    assert seen(with_gaps, publishers=2).lost == 3


def test_a_publisher_that_joins_with_a_higher_number_is_no_loss() -> None:
    """While the graph shows a publisher not yet known, a number that would leave a gap starts that publisher."""
    first, late = list(range(1, 60)), list(range(800, 850))
    assert (
        seen([*first[:30], *(n for pair in zip(first[30:], late, strict=False) for n in pair)], publishers=2).lost == 0
    )


def test_a_restarted_publisher_starts_afresh_and_the_old_one_is_forgotten() -> None:
    loss = seen([*range(1, 300), *range(1, 50)])
    assert loss.lost == 0 and [publisher.last for publisher in loss.publishers] == [49]
    loss.see(52)
    assert loss.lost == 2
