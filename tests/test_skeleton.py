"""Skeleton classification, its value semantics, and constraints."""

import copy
import pickle

import pytest

from sklearn_pycc.exceptions import SkeletonError
from sklearn_pycc.skeleton import Constraint, Skeleton, parse_constraints
from sklearn_pycc.skeleton.constraints import parse_constraint

DUFFING = ["x1_dot = x2", "x2_dot = F_ext - f1(x2) - f2(x1)"]


def error_of(equations, constraints=None):
    with pytest.raises(SkeletonError) as info:
        Skeleton(equations, constraints)
    return info.value


def assert_names_equation(err, index, position=None):
    assert err.equation == index
    assert f"equations[{index}]" in str(err)
    if position is not None:
        assert err.position == position
        assert str(err).splitlines()[-1] == "    " + " " * position + "^"


# --------------------------------------------------------------------------- classification
def test_duffing_skeleton_names():
    sk = Skeleton(DUFFING)
    assert sk.states == ["x1", "x2"]
    assert sk.derivatives == ["x1_dot", "x2_dot"]
    assert sk.inputs == ["F_ext"]
    assert sk.functions == ["f1", "f2"]
    assert sk.params == []
    assert sk.uses_time is False
    assert sk.equations == tuple(DUFFING)


def test_states_follow_equation_order():
    sk = Skeleton(["v_dot = -k x", "x_dot = v", "w_dot = x - w"])
    assert sk.states == ["v", "x", "w"]
    assert sk.derivatives == ["v_dot", "x_dot", "w_dot"]
    assert sk.inputs == ["k"]


def test_inputs_in_order_of_first_appearance():
    sk = Skeleton(["x1_dot = u2 + x2 u3", "x2_dot = u1 - u2 + F - x1 u3"])
    assert sk.inputs == ["u2", "u3", "u1", "F"]


def test_state_used_before_its_equation_is_not_an_input():
    sk = Skeleton(["x1_dot = x2 + u", "x2_dot = -x1"])
    assert sk.inputs == ["u"]
    assert sk.states == ["x1", "x2"]


def test_functions_and_params_sorted_by_numeric_index():
    sk = Skeleton(["x1_dot = a10 f10(x1) + a2 + f2(x1) + a1 f3(x1)"])
    assert sk.functions == ["f2", "f3", "f10"]
    assert sk.params == ["a1", "a2", "a10"]


def test_time_is_recognised():
    sk = Skeleton(["x1_dot = sin(t) - x1 + u t"])
    assert sk.uses_time is True
    assert "t" not in sk.inputs
    assert "t" not in sk.states
    assert sk.inputs == ["u"]
    assert "t" in sk.variables


def test_skeleton_without_time():
    sk = Skeleton(["x1_dot = -x1"])
    assert sk.uses_time is False
    assert "t" not in sk.variables


def test_variables_are_states_and_inputs_read():
    sk = Skeleton(["x1_dot = x2", "x2_dot = F - x1"])
    assert set(sk.variables) == {"x1", "x2", "F"}


def test_curve_and_parameter_shared_by_equations():
    sk = Skeleton(["x1_dot = f1(x1) + a1", "x2_dot = f1(x2) - a1 x1", "x3_dot = a1 f1(x3)"])
    assert sk.functions == ["f1"]
    assert sk.params == ["a1"]
    assert sk.states == ["x1", "x2", "x3"]


def test_hybrid_parametric_skeleton():
    sk = Skeleton(["x1_dot = x2", "x2_dot = -a1 x2 - a2 tanh(a3 x2) - f1(x1)"])
    assert sk.params == ["a1", "a2", "a3"]
    assert sk.functions == ["f1"]
    assert sk.inputs == []


def test_unsolved_first_order_family():
    sk = Skeleton(["F_ext = f1(x1) + f2(x1) x1_dot"])
    assert sk.derivatives == ["x1_dot"]
    assert sk.states == ["x1"]
    assert sk.inputs == ["F_ext"]
    assert sk.functions == ["f1", "f2"]
    (eq,) = sk.parsed
    assert eq.explicit is False
    assert eq.derivative == "x1_dot"
    assert eq.state == "x1"


def test_implicit_equation_next_to_explicit_ones():
    sk = Skeleton(["x1_dot = x2", "u = m x2_dot + f1(x2) + x1"])
    assert sk.derivatives == ["x1_dot", "x2_dot"]
    assert sk.states == ["x1", "x2"]
    assert sk.inputs == ["u", "m"]
    assert [eq.explicit for eq in sk.parsed] == [True, False]


def test_derivative_on_both_sides_is_implicit():
    sk = Skeleton(["x1_dot = a1 x1_dot + u"])
    assert sk.derivatives == ["x1_dot"]
    assert sk.parsed[0].explicit is False


def test_derivative_of_another_state_on_right_side():
    sk = Skeleton(["x1_dot = x2", "x2_dot = -x1 - 0.5 x1_dot"])
    assert sk.inputs == []
    assert all(eq.explicit for eq in sk.parsed)


def test_equations_from_any_iterable():
    assert Skeleton(tuple(DUFFING)) == Skeleton(DUFFING)
    assert Skeleton(e for e in DUFFING) == Skeleton(DUFFING)


# --------------------------------------------------------------------------- classification errors
def test_duplicate_left_hand_side():
    eqs = ["x1_dot = x2", "x2_dot = -x1", "x1_dot = x1"]
    err = error_of(eqs)
    assert_names_equation(err, 2, 0)
    assert "duplicate" in str(err)
    assert "x1_dot" in str(err)
    assert "equations[0]" in str(err)


def test_derivative_used_but_never_defined():
    text = "x2_dot = x3_dot - x2"
    err = error_of(["x1_dot = x2", text])
    assert_names_equation(err, 1, text.index("x3_dot"))
    assert "x3_dot is used but no equation defines it" in str(err)
    assert "x3" in str(err)


def test_derivative_used_but_never_defined_single_equation():
    err = error_of(["x1_dot = x2_dot - x1"])
    assert_names_equation(err, 0, 9)
    assert "x2_dot" in str(err)


def test_equation_without_derivative_and_nothing_to_fit():
    err = error_of(["x1_dot = x2", "x2 = x1 + 1"])
    assert_names_equation(err, 1)
    assert "no derivative" in str(err) and "nothing to fit" in str(err)


def test_implicit_equation_with_two_undefined_derivatives():
    text = "F = f1(x1) x1_dot + x2_dot"
    err = error_of([text])
    assert_names_equation(err, 0, text.index("x2_dot"))
    assert "x1_dot and x2_dot" in str(err)


def test_implicit_equation_that_determines_nothing():
    err = error_of(["x1_dot = x2", "x2_dot = -x1", "u = x1_dot + x2_dot"])
    assert_names_equation(err, 2)
    assert "nothing to fit" in str(err) and "already defined" in str(err)


def test_implicit_duplicate_of_explicit_equation():
    err = error_of(["x1_dot = x2", "x1_dot = x2 x1_dot + u"])
    assert_names_equation(err, 1)
    assert "already defined" in str(err)


def test_two_implicit_equations_for_one_derivative():
    # the first determines x1_dot; the second is a further relation, fitted too
    sk = Skeleton(["u = f1(x1) x1_dot", "v = f2(x1) x1_dot"])
    assert [eq.kind for eq in sk.residual_equations] == ["implicit", "algebraic"]
    assert sk.states == ["x1"] and sk.functions == ["f1", "f2"]


@pytest.mark.parametrize("text", ["x1_dot = trajectory", "x1_dot = x1 - f1(trajectory)"])
def test_trajectory_column_is_reserved(text):
    err = error_of(["x2_dot = x2", text])
    assert_names_equation(err, 1, text.index("trajectory"))
    assert "trajectory" in str(err)


@pytest.mark.parametrize("text", ["t_dot = 1", "x1_dot = t_dot + x1"])
def test_time_has_no_derivative(text):
    err = error_of([text])
    assert_names_equation(err, 0, text.index("t_dot"))
    assert "time" in str(err)


def test_parse_error_in_later_equation_names_it():
    err = error_of(["x1_dot = x2", "x2_dot = x1 +* 2"])
    assert_names_equation(err, 1, len("x2_dot = x1 +"))


# --------------------------------------------------------------------------- value semantics
def test_repr_without_constraints():
    assert repr(Skeleton(["x1_dot = -x1"])) == "Skeleton(['x1_dot = -x1'])"


def test_repr_with_constraints():
    sk = Skeleton(DUFFING, ["f1 odd", "f2(0)=0"])
    assert repr(sk) == (
        "Skeleton(['x1_dot = x2', 'x2_dot = F_ext - f1(x2) - f2(x1)'], "
        "constraints=['f1 odd', 'f2(0)=0'])"
    )


def test_str_lists_equations_and_constraints():
    sk = Skeleton(DUFFING, ["f1 odd", "f2(0)=0"])
    assert str(sk).splitlines() == [*DUFFING, "subject to: f1 odd, f2(0)=0"]
    assert str(Skeleton(DUFFING)).splitlines() == DUFFING


def test_equality_and_hash():
    a = Skeleton(DUFFING, ["f1 odd", "f2(0)=0"])
    b = Skeleton(list(DUFFING), ["f2(0)=0", {"constraint": "f1 odd"}])
    assert a == b
    assert hash(a) == hash(b)
    assert len({a, b}) == 1


def test_inequality():
    a = Skeleton(DUFFING, ["f1 odd"])
    assert a != Skeleton(DUFFING)
    assert a != Skeleton(DUFFING, ["f1 even"])
    assert a != Skeleton(["x1_dot = x2", "x2_dot = F_ext - f1(x2) - 2 f2(x1)"], ["f1 odd"])
    assert a != DUFFING
    assert a != "x1_dot = x2"


def test_pickle_round_trip():
    sk = Skeleton(["F_ext = f1(x1) + f2(x1) x1_dot"], ["f1 odd", "f2(1)=2.5"])
    back = pickle.loads(pickle.dumps(sk))
    assert back == sk
    assert hash(back) == hash(sk)
    assert back.states == sk.states
    assert back.inputs == sk.inputs
    assert back.functions == sk.functions
    assert back.constraints == sk.constraints
    assert [eq.explicit for eq in back.parsed] == [False]


def test_pickle_keeps_exact_constraint_values():
    sk = Skeleton(["x1_dot = f1(x1)"], ["f1(0.123456789)=1.000000001"])
    (c,) = pickle.loads(pickle.dumps(sk)).constraints
    assert c.at == 0.123456789
    assert c.value == 1.000000001


def test_deepcopy():
    sk = Skeleton(DUFFING, ["f1 odd"])
    dup = copy.deepcopy(sk)
    assert dup == sk
    assert dup is not sk
    assert dup.states == ["x1", "x2"]
    assert copy.copy(sk) == sk


def test_skeleton_of_skeleton_merges_constraints():
    base = Skeleton(DUFFING, ["f1 odd"])
    merged = Skeleton(base, ["f2(0)=0", "f1 odd"])
    assert merged.constraints == (Constraint("f1", "odd"), Constraint("f2", "value", 0.0, 0.0))
    assert merged.equations == base.equations
    assert base.constraints == (Constraint("f1", "odd"),)  # the original is untouched
    assert Skeleton(base) == base
    assert Skeleton(base, None) == base
    assert base.with_constraints(["f2(0)=0"]) == merged


def test_skeleton_of_skeleton_checks_merged_constraints():
    base = Skeleton(DUFFING, ["f1 odd"])
    with pytest.raises(SkeletonError, match="odd and even"):
        Skeleton(base, ["f1 even"])


def test_iteration_and_len():
    sk = Skeleton(DUFFING)
    assert len(sk) == 2
    assert list(sk) == DUFFING
    assert Skeleton(list(sk)) == sk


# --------------------------------------------------------------------------- constraints
@pytest.mark.parametrize(
    ("item", "expected"),
    [
        ("f1 odd", Constraint("f1", "odd")),
        ("f1 even", Constraint("f1", "even")),
        ("  f1   odd ", Constraint("f1", "odd")),
        ("f2(0)=0", Constraint("f2", "value", 0.0, 0.0)),
        ("f2( -1.5e-3 ) = 2.5E2", Constraint("f2", "value", -1.5e-3, 250.0)),
        ("f2(+1) = -2", Constraint("f2", "value", 1.0, -2.0)),
        ("f2(.5)=1.", Constraint("f2", "value", 0.5, 1.0)),
        ({"constraint": "f1 odd"}, Constraint("f1", "odd")),
        ({"constraint": "f2(1)=2.5"}, Constraint("f2", "value", 1.0, 2.5)),
    ],
)
def test_constraint_forms(item, expected):
    assert parse_constraint(item) == expected
    assert Skeleton(DUFFING, [item]).constraints == (expected,)


def test_constraint_str_reparses():
    for text in ["f1 odd", "f2 even", "f2(-0.0015)=250", "f1(0)=0"]:
        c = parse_constraint(text)
        assert str(c) == text
        assert parse_constraint(str(c)) == c


def test_single_constraint_string_and_none():
    assert parse_constraints("f1 odd") == (Constraint("f1", "odd"),)
    assert parse_constraints({"constraint": "f1 even"}) == (Constraint("f1", "even"),)
    assert parse_constraints(None) == ()
    assert Skeleton(DUFFING, "f1 odd").constraints == (Constraint("f1", "odd"),)


def test_constraint_objects_are_accepted():
    c = Constraint("f2", "value", 0.0, 0.0)
    assert Skeleton(DUFFING, [c, "f2(0)=0"]).constraints == (c,)


def test_duplicate_constraints_are_merged():
    sk = Skeleton(
        DUFFING,
        ["f1 odd", {"constraint": "f1 odd"}, "f1  odd", "f2(1)=2", "f2(1.0)=2.0", "f2(1e0)=2"],
    )
    assert sk.constraints == (Constraint("f1", "odd"), Constraint("f2", "value", 1.0, 2.0))


def test_constraints_of():
    sk = Skeleton(DUFFING, ["f1 odd", "f2(0)=0", "f2(1)=1"])
    assert sk.constraints_of("f1") == [Constraint("f1", "odd")]
    assert [c.at for c in sk.constraints_of("f2")] == [0.0, 1.0]


def test_consistent_symmetric_points_are_accepted():
    sk = Skeleton(
        DUFFING, ["f1 odd", "f1(0)=0", "f1(2)=1", "f1(-2)=-1", "f2 even", "f2(1)=2", "f2(-1)=2"]
    )
    assert len(sk.constraints) == 7


def assert_constraint_error(err, index, position):
    assert err.equation == index
    assert err.position == position
    assert f"constraints[{index}]" in str(err)
    assert str(err).splitlines()[-1] == "    " + " " * position + "^"


@pytest.mark.parametrize(
    ("text", "position"),
    [
        ("f1 monotone", 3),
        ("x1 odd", 0),
        ("f1(0)", 5),
        ("f1 odd please", 7),
        ("f1(x1)=0", 3),
        ("f1(0)=x1", 6),
        ("f1(0=1", 4),
        ("f1(0)=1 2", 8),
        ("odd f1", 0),
        ("", 0),
    ],
)
def test_unknown_constraint(text, position):
    err = error_of(DUFFING, ["f2(0)=0", text])
    assert_constraint_error(err, 1, position)
    assert err.text == text


def test_unknown_constraint_message_shows_usage():
    err = error_of(DUFFING, ["f1 monotone"])
    assert "unknown constraint" in str(err)
    assert "odd" in str(err)
    assert "f1 monotone" in str(err)


def test_dict_constraint_with_wrong_key():
    err = error_of(DUFFING, ["f1 odd", {"constriant": "f2 odd"}])
    assert err.equation == 1
    assert "constraints[1]" in str(err)
    assert "'constriant'" in str(err)


def test_dict_constraint_with_extra_key():
    err = error_of(DUFFING, [{"constraint": "f1 odd", "weight": 2}])
    assert "constraints[0]" in str(err)
    assert "weight" in str(err)


@pytest.mark.parametrize("item", [3, 1.5, None, ["f1 odd"], {"constraint": 7}])
def test_non_string_constraint(item):
    err = error_of(DUFFING, ["f1 odd", item])
    assert err.equation == 1
    assert "constraints[1]" in str(err)
    assert repr(item) in str(err)


def test_constraint_on_missing_curve():
    err = error_of(DUFFING, ["f1 odd", "f3 even"])
    assert "f3 even" in str(err)
    assert "f1, f2" in str(err)


def test_constraint_on_skeleton_without_curves():
    err = error_of(["x1_dot = -a1 x1"], ["f1(0)=0"])
    assert "f1(0)=0" in str(err)
    assert "no curves" in str(err)


def culprits(err):
    """The constraints a contradiction message blames, before its 'require both ...'."""
    message = str(err)
    assert "contradictory constraints on" in message
    blamed = message.split(": ", 1)[1].split(" require both ")[0]
    return set(blamed.split(", "))


def test_contradiction_odd_and_even():
    err = error_of(DUFFING, ["f1 odd", "f2 odd", "f1 even"])
    assert "contradictory" in str(err)
    assert "f1" in str(err)
    assert "odd and even" in str(err)


def test_contradiction_odd_with_nonzero_origin():
    err = error_of(DUFFING, ["f1 odd", "f1(0)=1"])
    assert culprits(err) == {"f1 odd", "f1(0)=1"}
    assert "-0" not in str(err)


def test_contradiction_odd_with_symmetric_equal_values():
    err = error_of(DUFFING, ["f1 odd", "f1(1)=2", "f1(-1)=2"])
    assert culprits(err) == {"f1 odd", "f1(1)=2", "f1(-1)=2"}


def test_contradiction_even_with_different_values():
    err = error_of(DUFFING, ["f1 even", "f1(1)=2", "f1(-1)=3"])
    assert culprits(err) == {"f1 even", "f1(1)=2", "f1(-1)=3"}


def test_contradiction_two_values_at_one_point():
    err = error_of(DUFFING, ["f2(0)=0", "f1(1)=2", "f1(1)=3"])
    assert culprits(err) == {"f1(1)=2", "f1(1)=3"}
    assert "f2" not in str(err)


def test_contradiction_is_a_skeleton_error_and_value_error():
    with pytest.raises(ValueError):
        Skeleton(DUFFING, ["f1(1)=2", "f1(1)=3"])


def test_cycle_between_derivatives_is_rejected_at_construction():
    from sklearn_pycc import Skeleton, SkeletonError

    with pytest.raises(SkeletonError, match="cycle"):
        Skeleton(["x1_dot = x2_dot", "x2_dot = x1_dot"])


# -- adding a term ---------------------------------------------------------------------
LINEAR = ["x1_dot = x2", "x2_dot = F_ext - a1 x2 - a2 x1"]


def test_add_term_renumbers_to_fresh_indices():
    sk = Skeleton(LINEAR)
    extended = sk.add_term("x2", "a1 sign(x2)")
    assert extended.equations == ("x1_dot = x2", "x2_dot = F_ext - a1 x2 - a2 x1 - a3*sign(x2)")
    assert extended.params == ["a1", "a2", "a3"]
    assert sk.equations == tuple(LINEAR)  # unchanged
    two = sk.add_term(1, "a7 tanh(a2 x2)", sign="+")
    # renumbered in the order of the term's own indices
    assert two.equations[1] == "x2_dot = F_ext - a1 x2 - a2 x1 + a4*tanh(a3*x2)"


@pytest.mark.parametrize("equation", [1, -1, "x2", "x2_dot"])
def test_add_term_finds_the_equation(equation):
    extended = Skeleton(LINEAR).add_term(equation, "a1 x1^3")
    assert extended.equations[1].endswith("- a3*x1^3")
    assert extended.equations[0] == "x1_dot = x2"


def test_add_term_with_curves_and_their_constraints():
    sk = Skeleton(["x1_dot = x2", "x2_dot = F_ext - f1(x2) - f3(x1)"], ["f1 odd"])
    extended = sk.add_term("x2", "f1(x1 - x2) + a1 x2", constraints=["f1 odd", "f1(0)=0"])
    assert extended.equations[1] == "x2_dot = F_ext - f1(x2) - f3(x1) - (f4(x1 - x2) + a1*x2)"
    assert [str(c) for c in extended.constraints] == ["f1 odd", "f4 odd", "f4(0)=0"]


def test_add_term_keeps_a_leading_minus_readable():
    extended = Skeleton(LINEAR).add_term("x2", "-a1 x1")
    assert extended.equations[1] == "x2_dot = F_ext - a1 x2 - a2 x1 - (-a3*x1)"
    refit = Skeleton(list(extended.equations))
    assert refit.params == ["a1", "a2", "a3"]


def test_add_term_bad_input():
    sk = Skeleton(LINEAR)
    with pytest.raises(ValueError, match="no equation determines 'x3'"):
        sk.add_term("x3", "a1 x1")
    with pytest.raises(IndexError, match="no equation 2"):
        sk.add_term(2, "a1 x1")
    with pytest.raises(TypeError, match="equation must be"):
        sk.add_term(1.5, "a1 x1")
    with pytest.raises(ValueError, match="sign must be"):
        sk.add_term("x2", "a1 x1", sign="*")
    with pytest.raises(SkeletonError, match="position"):
        sk.add_term("x2", "a1 sign(x2")
    with pytest.raises(SkeletonError, match="f2"):
        sk.add_term("x2", "f1(x2)", constraints=["f2 odd"])
