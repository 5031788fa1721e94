import json
import math
from pathlib import Path

import numpy as np
from hypothesis import given
from hypothesis import strategies as st

from umbmark.jsonutil import dumps, jsonable

leaf = st.one_of(st.none(), st.booleans(), st.integers(-(10**6), 10**6), st.floats(), st.text(max_size=5))
tree = st.recursive(
    leaf,
    lambda c: st.one_of(st.lists(c, max_size=4), st.dictionaries(st.text(max_size=4), c, max_size=4)),
    max_leaves=20,
)


@given(tree)
def test_any_tree_becomes_strict_json(o):
    text = dumps(o)
    # strict JSON: a parser that refuses NaN / Infinity constants reads it
    back = json.loads(text, parse_constant=lambda c: (_ for _ in ()).throw(ValueError(c)))
    assert json.loads(dumps(back)) == back


def test_numpy_and_paths():
    d = jsonable(
        {"a": np.float64(1.5), "b": np.array([1.0, np.nan]), "c": np.int64(3), "p": Path("x/y"), "t": (np.inf, -0.0)}
    )
    assert d == {"a": 1.5, "b": [1.0, None], "c": 3, "p": "x/y", "t": [None, -0.0]}
    assert type(d["a"]) is float and type(d["c"]) is int
    assert math.copysign(1, d["t"][1]) < 0
