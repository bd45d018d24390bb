"""core/heap: what is set aside from the cyclic collector goes back to it when the block ends."""

from __future__ import annotations

import gc
import weakref

from kbplanner.core.heap import _after_full, frozen, growing, set_aside


class _Node:
    def __init__(self) -> None:
        self.me = self  # a cycle: freed by the collector only


def test_set_aside_objects_are_frozen_until_the_block_ends() -> None:
    gc.collect()
    assert gc.get_freeze_count() == 0
    with frozen():
        node = _Node()
        gone = weakref.ref(node)
        set_aside()
        assert gc.get_freeze_count() > 0
        del node
        gc.collect()
        assert gone() is not None  # set aside: the collector does not visit it
    assert gc.get_freeze_count() == 0
    gc.collect()
    assert gone() is None  # back to the collector: freed


def test_a_nested_block_leaves_the_outer_ones_set_aside() -> None:
    with frozen():
        set_aside()
        with frozen():
            set_aside()
        assert gc.get_freeze_count() > 0
    assert gc.get_freeze_count() == 0


def test_recent_garbage_is_collected_before_it_is_set_aside() -> None:
    with frozen():
        node = _Node()
        gone = weakref.ref(node)
        del node
        set_aside()
        assert gone() is None


def test_a_full_collection_while_growing_sets_the_survivors_aside() -> None:
    with frozen():
        with growing():
            kept = [_Node() for _ in range(10)]
            gc.collect()  # a full collection: its survivors set aside
            assert gc.get_freeze_count() >= len(kept)
        assert _after_full not in gc.callbacks  # only while growing
    assert gc.get_freeze_count() == 0
