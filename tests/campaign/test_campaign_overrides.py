"""Dotted-key overrides on a scenario mapping: nested create, list index, no mutation, clear errors."""

import copy

import pytest
from hypothesis import given
from hypothesis import strategies as st

from agvnav.campaign import apply_overrides, set_dotted

BASE = {"a": {"b": 1, "c": [{"d": 2}, {"d": 3}]}, "e": 4}


def test_set_nested_and_list_item():
    out = set_dotted(BASE, "a.c.1.d", 9)
    assert out["a"]["c"][1]["d"] == 9 and BASE["a"]["c"][1]["d"] == 3
    assert set_dotted(BASE, "x.y", 1)["x"] == {"y": 1}


def test_apply_in_order_without_mutating():
    before = copy.deepcopy(BASE)
    out = apply_overrides(BASE, {"a.b": 5, "a": {"z": 1}, "a.y": 2})
    assert out == {"a": {"z": 1, "y": 2}, "e": 4} and before == BASE


@pytest.mark.parametrize(
    ("key", "needle"), [("e.f", "is a value (4)"), ("a.c.2.d", "not an index"), ("a.c.x", "not an index")]
)
def test_bad_keys(key, needle):
    with pytest.raises(ValueError, match=needle.replace("(", r"\(").replace(")", r"\)")):
        set_dotted(BASE, key, 0)


names = st.text(alphabet="wxyz_", min_size=1, max_size=4)  # never an existing key of BASE


@given(
    st.sampled_from([[], ["a"], ["a", "c", "0"]]),
    st.lists(names, min_size=1, max_size=3),
    st.one_of(st.integers(), st.floats(allow_nan=False), names, st.lists(st.integers(), max_size=2)),
)
def test_set_then_get(prefix, new, value):
    parts = prefix + new
    out = set_dotted(BASE, ".".join(parts), value)
    node = out
    for p in parts:
        node = node[int(p)] if isinstance(node, list) else node[p]
    assert node == value
    assert BASE == {"a": {"b": 1, "c": [{"d": 2}, {"d": 3}]}, "e": 4}  # the input is never mutated
    untouched = {k: v for k, v in BASE.items() if k != parts[0]}
    assert {k: out[k] for k in untouched} == untouched
