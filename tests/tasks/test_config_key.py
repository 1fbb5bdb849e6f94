"""Key: what one config key accepts, in words and in ``check``; Source: where values come from
(the messages' prefix)."""

from __future__ import annotations

import numpy as np
import pytest

from trossen_arm_mujoco.errors import UserError
from trossen_arm_mujoco.tasks.config_key import Key, Source


@pytest.mark.parametrize(
    "key, text",
    [
        (Key("number", 0.0, 1.0, True, unit="m"), "a number in (0, 1] m"),
        (Key("number", 0.0), "a number >= 0"),
        (Key("number"), "a finite number"),
        (Key("int", 1, 100), "a whole number in [1, 100]"),
        (Key("vector", -1.0, 1.0, lengths=(2, 3)), "a list of 2 or 3 numbers, each in [-1, 1]"),
        (Key("choice", choices=("a", "b")), "one of a, b"),
        (Key("bool"), "true/false"),
    ],
)
def test_key_describes_what_is_valid(key, text):
    assert key.describe() == text


def test_check_converts_or_says_what_is_valid():
    where = Source.file("reach.yaml").where("policy_dt")
    assert where == "config file reach.yaml, key policy_dt"
    assert Key("int", 1, 10).check(where, np.int64(3)) == 3
    assert Key("int", 1, 10).check(where, 4.0) == 4
    assert Key("vector", lengths=(2,)).check(where, np.array([1, 2])) == [1.0, 2.0]
    assert Key("bool").check(where, np.True_) is True
    with pytest.raises(UserError, match=r"key policy_dt: expected a number in \(0, 1\], got nan"):
        Key("number", 0.0, 1.0, True).check(where, float("nan"))
    with pytest.raises(UserError, match="expected a whole number"):
        Key("int", 1, 10).check(where, 2.5)
    with pytest.raises(UserError, match="expected a finite number, got True"):
        Key("number").check(where, True)  # a bool is not a number
    over = Source.overrides("push").where("cube_low")
    assert over == "task config 'push', keyword argument cube_low"
    with pytest.raises(UserError, match=r"expected a list of 2 numbers \(as in the task's file\)"):
        Key("vector", lengths=(2, 3)).check(over, [1.0, 2.0, 3.0], length=2)
