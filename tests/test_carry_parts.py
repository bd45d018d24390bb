"""B4's carry-leg check (planning/carry_parts.py): the label pairs that join two footprints' components
are the same whether counted per key or taken as unique keys, and joint_components joins through them."""

from __future__ import annotations

import numpy as np
import pytest

import kbplanner.planning.carry_parts as cp


def _unique_pairs(li: np.ndarray, lj: np.ndarray, nj: int) -> np.ndarray:
    both = (li > 0) & (lj > 0)
    return np.unique(li[both].astype(np.int64) * nj + lj[both])


@pytest.mark.parametrize(("ni", "nj", "seed"), [(4, 2, 0), (7, 9, 1), (2, 2, 2), (300, 500, 3)])
def test_label_pairs_are_the_unique_pairs_of_labels_free_in_both(ni: int, nj: int, seed: int) -> None:
    rng = np.random.default_rng(seed)
    li = rng.integers(0, ni, (6, 20, 30)).astype(np.int32)
    lj = rng.integers(0, nj, (6, 20, 30)).astype(np.int32)
    dense = cp._label_pairs(li, ni, lj, nj)
    assert dense.dtype == np.int64
    np.testing.assert_array_equal(dense, _unique_pairs(li, lj, nj))
    old = cp.DENSE_PAIR_KEYS
    try:  # the other branch: unique keys
        cp.DENSE_PAIR_KEYS = 0
        np.testing.assert_array_equal(cp._label_pairs(li, ni, lj, nj), dense)
    finally:
        cp.DENSE_PAIR_KEYS = old


def test_joint_components_joins_labels_that_share_a_free_cell() -> None:
    # footprint A: labels 1 (left) and 2 (right); footprint B: label 1 spans both, so A's 1 and 2 join
    li = np.array([[[1, 1, 0, 2, 2]]], dtype=np.int32)
    lj = np.array([[[0, 1, 1, 1, 0]]], dtype=np.int32)
    roots_i = np.array([0, 1, 2], dtype=np.int64)
    roots_j = np.array([0, 1], dtype=np.int64)
    offsets, joint = cp.joint_components([(li, roots_i), (lj, roots_j)])
    assert offsets == (0, 3)
    assert joint[1] == joint[2] == joint[3 + 1]
    assert joint[0] != joint[1]  # label 0 (not free) joins nothing
    # without the shared cells A's two labels stay apart
    lj_apart = np.array([[[0, 1, 0, 0, 0]]], dtype=np.int32)
    _, joint = cp.joint_components([(li, roots_i), (lj_apart, roots_j)])
    assert joint[1] != joint[2]
