"""Malformed and hostile skeleton text: only SkeletonError, always with a position."""

import string

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from sklearn_pycc import Skeleton, SkeletonError
from sklearn_pycc.skeleton.parser import MAX_DEPTH, MAX_NESTING


def _error(text):
    with pytest.raises(SkeletonError) as info:
        Skeleton([text])
    return info.value


@pytest.mark.parametrize("text, words", [
    ("x1_dot = " + "(" * 200 + "x1" + ")" * 200, f"more than {MAX_NESTING} levels"),
    ("x1_dot = " + "tanh(" * 200 + "x1" + ")" * 200, f"more than {MAX_NESTING} levels"),
    ("x1_dot = x1" + "^x1" * 300, f"more than {MAX_NESTING} levels"),
    ("x1_dot = " + " + ".join(f"a{i} x1" for i in range(1, 501)), f"{MAX_DEPTH} levels"),
    ("x1_dot = " + " ".join(["x1"] * 500), f"{MAX_DEPTH} levels"),
    ("x1_dot = x1²", "superscript"),
    ("x1_dot = ² x1", "superscript"),
    ("x1_dot = ٣ x1", "digits 0-9"),
    ("x1_dot = \uff11 x1", "digits 0-9"),  # fullwidth one
    ("x1_dot = 1e999 x1", "too large"),
    ("x1_dot = 1e-999 x1", "too small"),
    ("x1_dot = log(-1) x1", "log(-1)"),
    ("x1_dot = sqrt(-1) x1", "sqrt(-1)"),
    ("x1_dot = exp(1000) x1", "exp(1000)"),
    ("x1_dot = x1 / (2 - 2)", "division by a constant zero"),
    ("x1_dot = (-8)^(1/3) x1", "no finite real value"),
    ("x1_dot = 10^400 x1", "no finite real value"),
    ("pi_dot = -a1 pi", "constant pi"),
    ("a1_dot = -x1", "unknown parameter"),
    ("f2_dot = -x1", "unknown curve"),
    ("tanh_dot = -x1", "function tanh"),
])
def test_hostile_text_is_a_skeleton_error_with_equation_and_position(text, words):
    error = _error(text)
    assert words in str(error)
    assert error.equation == 0
    assert error.position is not None and 0 <= error.position <= len(text)


def test_a_long_run_of_signs_folds_without_recursion():
    even = Skeleton(["x1_dot = " + "-" * 10_000 + "x1"])
    assert even.parsed[0].rhs.name == "x1"
    odd = Skeleton(["x1_dot = " + "-" * 9_999 + "a1 x1"])
    assert odd.params == ["a1"]
    from sklearn_pycc.skeleton.printer import to_text

    assert to_text(odd.parsed[0].rhs).replace(" ", "") == "-a1*x1"


def test_the_position_points_at_the_culprit():
    text = "x1_dot = a1 x1 + ٣"
    assert _error(text).position == text.index("٣")
    text = "x1_dot = -a1 x1 + log(-1)"
    assert _error(text).position == text.index("log")


def test_constants_that_have_values_are_kept():
    skeleton = Skeleton(["x1_dot = -exp(-1000) x1 + sqrt(4) a1 + 2^-3 x1 + 1e-300 x1"])
    assert skeleton.params == ["a1"]


_ALPHABET = string.ascii_letters[:12] + string.digits + "_ +-*/^().,=²٣\uff11<>'\"[]:;!\t"
_TOKENS = ["x1", "x2", "x1_dot", "x2_dot", "a1", "a2", "f1", "f2", "(", ")", "+", "-", "*",
           "/", "^", "**", "=", " ", "tanh(", "sqrt(", "log(", "1e999", "0", "2.5", "pi",
           "pi_dot", "F_ext", ",", "1/0", "exp(", "sign(", "t", "trajectory", "__x"]


@pytest.mark.slow
@settings(max_examples=1500, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(st.one_of(st.text(_ALPHABET, max_size=60),
                 st.lists(st.sampled_from(_TOKENS), max_size=40).map("".join)))
def test_fuzzed_text_raises_only_skeleton_errors(text):
    try:
        Skeleton([text])
    except SkeletonError as error:
        assert error.equation == 0
