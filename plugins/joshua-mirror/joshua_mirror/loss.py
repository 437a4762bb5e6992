"""Messages lost between a publisher and the mirror, counted from the publishers' sequence numbers.

Every DDS publisher numbers its messages 1, 2, 3 ...; the subscription sees each message's number in its
message info (`publication_sequence_number`). A gap in one publisher's numbers is messages lost anywhere on the
way: dropped by the network, or overwritten in the subscription's keep-last queue because the mirror fell
behind. rclpy's message info names no publisher, so messages are matched to publishers by their numbers:
each one continues the known publisher whose last number is the nearest below it. Without loss that match is
exact (the publisher at n - 1 is there); a number with no publisher below it, or one that would leave a gap
while the graph shows more publishers on the topic than are known, starts a new publisher (one that just came,
or came back). Loss at the very end of a publisher's messages shows no gap and is not counted.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass, field


@dataclass
class _Publisher:
    last: int  # the last sequence number seen
    seen_at: float  # monotonic seconds, when it was seen


@dataclass
class TopicLoss:
    """The lost-message count of one topic and the publishers it knows there."""

    publisher_count: Callable[[], int]  # how many publishers the ROS graph shows on the topic (asked on gaps only)
    lost: int = 0
    publishers: list[_Publisher] = field(default_factory=list)

    def see(self, sequence: int) -> None:
        """Count the gap before a message with this publication sequence number (one call per message, any thread
        but always the same one)."""
        below = None
        for publisher in self.publishers:
            if publisher.last < sequence and (below is None or publisher.last > below.last):
                below = publisher
        now = time.monotonic()
        if below is not None and below.last == sequence - 1:
            below.last, below.seen_at = sequence, now
            return
        count = self.publisher_count()
        if below is None or len(self.publishers) < count:
            self.publishers.append(_Publisher(sequence, now))
            # publishers that left are forgotten, the longest unheard first
            self.publishers.sort(key=lambda known: known.seen_at, reverse=True)
            del self.publishers[max(count, 1) :]
            return
        self.lost += sequence - below.last - 1
        below.last, below.seen_at = sequence, now
