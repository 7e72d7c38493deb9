"""The shared thread pool's slicing, against a plain range."""

import numpy as np
import pytest

from core.geometry.parallel import map_chunks


@pytest.mark.parametrize("threads", [1, 2, 3])
@pytest.mark.parametrize("n, block", [(0, 7), (1, 7), (100, 7), (100, 1000), (10_007, 64), (5000, None)])
def test_pieces_cover_the_range_once_in_order_and_none_is_longer_than_block(threads, n, block):
    pieces = map_chunks(lambda sl: (sl.start, sl.stop), n, min_chunk=10, threads=threads, block=block)
    items = np.concatenate([np.arange(a, b) for a, b in pieces]) if pieces else np.zeros(0)
    np.testing.assert_array_equal(items, np.arange(n))
    if block:
        assert max(b - a for a, b in pieces) <= block
        # a thread's slice is cut into pieces, not the whole range into one slice per piece
        assert len(pieces) >= -(-n // block)
