"""Grammar of the skeleton language: parse trees, compiled values, error messages, injection."""

import builtins
import itertools
import os

import numpy as np
import pytest

from sklearn_pycc.exceptions import SkeletonError
from sklearn_pycc.skeleton import (
    Apply,
    BinOp,
    Neg,
    Number,
    Param,
    Skeleton,
    Symbol,
    Unknown,
    parse_equation,
    parse_expression,
)
from sklearn_pycc.skeleton.compiler import compile_expression
from sklearn_pycc.skeleton.functions import ELEMENTARY

MODES = ["array", "scalar"]

# sample points for the variables of the value tests
POINTS = {
    "x": np.array([-1.3, -0.4, 0.0, 0.6, 2.2]),
    "y": np.array([0.5, -2.0, 1.7, 0.3, -0.8]),
    "z": np.array([1.1, 0.9, 0.2, 2.0, 0.4]),  # positive: a base of real powers
    "t": np.array([0.0, 0.25, 1.0, 3.5, 10.0]),
}


def evaluate(text, mode, params=None, functions=None, points=None):
    """Parse ``text`` as an expression, compile it and evaluate it on the sample points."""
    points = POINTS if points is None else points
    node = parse_expression(text)
    names = list(points)
    slots = {name: i for i, name in enumerate(names)}
    fn = compile_expression(node, slots, params, functions, mode=mode)
    n = len(next(iter(points.values())))
    if mode == "array":
        env = [np.asarray(points[name], dtype=float) for name in names]
        return np.broadcast_to(np.asarray(fn(env), dtype=float), (n,))
    out = []
    for k in range(n):
        value = fn([float(points[name][k]) for name in names])
        assert isinstance(value, float), f"scalar mode returned {type(value).__name__}"
        out.append(value)
    return np.array(out)


def check_values(text, expected, mode, params=None, functions=None, points=None):
    got = evaluate(text, mode, params, functions, points)
    expected = np.broadcast_to(np.asarray(expected, dtype=float), got.shape)
    np.testing.assert_allclose(got, expected, rtol=1e-12, atol=1e-14)


X, Y, Z, T = POINTS["x"], POINTS["y"], POINTS["z"], POINTS["t"]


# --------------------------------------------------------------------------- trees
def test_equation_returns_both_sides():
    lhs, rhs = parse_equation("x1_dot = x2")
    assert lhs == Symbol("x1_dot")
    assert rhs == Symbol("x2")


@pytest.mark.parametrize("text", ["x1_dot=x2", "  x1_dot\t=   x2  ", "x1_dot =\nx2"])
def test_whitespace_is_insignificant(text):
    assert parse_equation(text) == (Symbol("x1_dot"), Symbol("x2"))


def test_source_positions_are_recorded():
    lhs, rhs = parse_equation("x1_dot = a1 x2")
    assert lhs.pos == 0
    assert rhs.left.pos == 9
    assert rhs.right.pos == 12


def test_implicit_multiplication_tree():
    assert parse_expression("a1 x2") == BinOp("*", Param("a1"), Symbol("x2"))


def test_implicit_multiplication_of_parameter_and_function():
    expected = BinOp("*", Param("a2"), Apply("tanh", BinOp("*", Param("a3"), Symbol("x2"))))
    assert parse_expression("a2 tanh(a3 x2)") == expected


def test_number_times_parenthesis_tree():
    expected = BinOp("*", Number(2.0), BinOp("+", Symbol("x"), Number(1.0)))
    assert parse_expression("2(x+1)") == expected


def test_parenthesis_times_parenthesis_tree():
    assert parse_expression("(x1)(x2)") == BinOp("*", Symbol("x1"), Symbol("x2"))


def test_unary_minus_binds_looser_than_power():
    expected = Neg(BinOp("^", Symbol("x"), Number(2.0)))
    assert parse_expression("-x^2") == expected
    assert parse_expression("-x**2") == expected


def test_negative_exponent():
    assert parse_expression("2^-1") == BinOp("^", Number(2.0), Neg(Number(1.0)))


def test_power_is_right_associative_tree():
    expected = BinOp("^", Symbol("x"), BinOp("^", Symbol("y"), Symbol("z")))
    assert parse_expression("x^y^z") == expected
    assert parse_expression("x**y**z") == expected


def test_double_star_and_caret_are_the_same_operator():
    assert parse_expression("x**3") == parse_expression("x^3")


def test_unknown_curve_with_expression_argument_tree():
    node = parse_expression("f2(x1 - x2)")
    assert node == Unknown("f2", BinOp("-", Symbol("x1"), Symbol("x2")))


def test_pi_is_a_number():
    assert parse_expression("pi") == Number(np.pi)


def test_time_is_a_symbol():
    assert parse_expression("t") == Symbol("t")


def test_parameters_and_curves_are_recognised_by_name():
    node = parse_expression("a12 + f7(x)")
    assert node == BinOp("+", Param("a12"), Unknown("f7", Symbol("x")))


def test_unary_plus_is_dropped():
    assert parse_expression("+x") == Symbol("x")


def test_unary_minus_on_implicit_product_scope():
    # -2 x is (-2) x; the value is the same as -(2 x)
    assert parse_expression("-2 x") == BinOp("*", Neg(Number(2.0)), Symbol("x"))


# --------------------------------------------------------------------------- values
@pytest.mark.parametrize("mode", MODES)
@pytest.mark.parametrize(
    ("text", "expected"),
    [
        ("2^3^2", 512.0),
        ("2**3**2", 512.0),
        ("-2^2", -4.0),
        ("(-2)^2", 4.0),
        ("2^-1", 0.5),
        ("2**-1", 0.5),
        ("-2^-2", -0.25),
        ("2^-1^2", 0.5),
        ("8 - 3 - 2", 3.0),
        ("8 / 4 / 2", 1.0),
        ("1 + 2 * 3", 7.0),
        ("3 (1 + 2)", 9.0),
        ("2(3+1)", 8.0),
        ("(2)(5)", 10.0),
        ("1e-3", 1e-3),
        ("1.5E+3", 1500.0),
        ("2.5e2", 250.0),
        ("3E-2", 0.03),
        (".5", 0.5),
        ("2.", 2.0),
        ("0.125", 0.125),
        ("pi", np.pi),
        ("2 pi", 2 * np.pi),
        ("cos(pi)", -1.0),
        ("--3", 3.0),
        ("- + - 3", 3.0),
    ],
)
def test_constant_expressions(text, expected, mode):
    check_values(text, expected, mode)


@pytest.mark.parametrize("mode", MODES)
@pytest.mark.parametrize(
    ("text", "expected"),
    [
        ("x y", X * Y),
        ("x y z", X * Y * Z),
        ("2 x", 2 * X),
        ("2(x+1)", 2 * (X + 1)),
        ("(x)(y)", X * Y),
        ("(x + y)(x - y)", (X + Y) * (X - Y)),
        ("2 x^2", 2 * X**2),
        ("x^2 y", X**2 * Y),
        ("-x^2", -(X**2)),
        ("-x**2", -(X**2)),
        ("x - y", X - Y),
        ("x -y", X - Y),
        ("x - -y", X + Y),
        ("x / y z", X / Y * Z),
        ("x / (y z)", X / (Y * Z)),
        ("z^y^2", Z ** (Y**2)),
        ("z^-y", Z ** (-Y)),
        ("z^0", np.ones_like(Z)),
        ("x^1", X),
        ("x^3", X**3),
        ("x^4", X**4),
        ("x^7", X**7),
        ("1e-3 x", 1e-3 * X),
        ("1.5E+3 x", 1500.0 * X),
        (".5 x", 0.5 * X),
        ("x + 1e3", X + 1000.0),
        ("pi x", np.pi * X),
        ("sin(pi t)", np.sin(np.pi * T)),
        ("t^2 / 2", T**2 / 2),
        ("x + 0", X),
        ("0 + x", X),
        ("1 * x", X),
        ("x * 1", X),
        ("x - 0", X),
        ("0 - x", -X),
    ],
)
def test_expressions_with_variables(text, expected, mode):
    check_values(text, expected, mode)


@pytest.mark.parametrize("mode", MODES)
@pytest.mark.parametrize("op", ["+", "-", "*", "/"])
def test_every_operator_with_variables_constants_and_expressions_on_each_side(op, mode):
    # the compiler reads a variable from its slot and a constant inline: every pairing
    apply = {"+": np.add, "-": np.subtract, "*": np.multiply, "/": np.divide}[op]
    sides = {"z": Z, "2.5": 2.5, "sin(y)": np.sin(Y), "a1": 0.7}
    for (left, lv), (right, rv) in itertools.product(sides.items(), repeat=2):
        if isinstance(lv, float) and isinstance(rv, float):
            continue  # folded: covered by the constant expressions
        expected = np.broadcast_to(apply(lv, rv), Z.shape)
        check_values(f"({left}) {op} ({right})", expected, mode, params={"a1": 0.7})


@pytest.mark.parametrize("mode", MODES)
def test_fractional_and_variable_powers(mode):
    points = {"u": np.array([0.1, 0.5, 2.0, 9.0]), "v": np.array([-1.5, 0.3, 2.0, 0.5])}
    u, v = points["u"], points["v"]
    check_values("u^0.5", np.sqrt(u), mode, points=points)
    check_values("u^v", u**v, mode, points=points)
    check_values("u^-v^2", u ** (-(v**2)), mode, points=points)
    check_values("u^(1/3) v", np.cbrt(u) * v, mode, points=points)


@pytest.mark.parametrize("mode", MODES)
def test_parameters_are_substituted(mode):
    params = {"a1": 0.7, "a2": -1.5, "a3": 2.0}
    check_values("a1 x", 0.7 * X, mode, params=params)
    check_values("a2 tanh(a3 y)", -1.5 * np.tanh(2.0 * Y), mode, params=params)
    check_values("a1 x - a2 tanh(a3 x)", 0.7 * X + 1.5 * np.tanh(2.0 * X), mode, params=params)
    check_values("a3^a1", 2.0**0.7, mode, params=params)


@pytest.mark.parametrize("mode", MODES)
def test_unknown_curve_of_expression(mode):
    functions = {"f2": lambda v: v**3 - v, "f1": lambda v: 0.5 * v}
    check_values("f2(x - y)", (X - Y) ** 3 - (X - Y), mode, functions=functions)
    check_values("z - f1(y) - f2(x)", Z - 0.5 * Y - (X**3 - X), mode, functions=functions)
    check_values("f1(f2(x))", 0.5 * (X**3 - X), mode, functions=functions)
    check_values("f1(2)", 1.0, mode, functions=functions)


@pytest.mark.parametrize("mode", MODES)
def test_time_symbol_is_read_from_its_slot(mode):
    check_values("t x", T * X, mode)


# every elementary function with an independent numpy reference
REFERENCE = {
    "sin": np.sin,
    "cos": np.cos,
    "tan": np.tan,
    "sinh": np.sinh,
    "cosh": np.cosh,
    "tanh": np.tanh,
    "arcsin": np.arcsin,
    "arccos": np.arccos,
    "arctan": np.arctan,
    "asin": np.arcsin,
    "acos": np.arccos,
    "atan": np.arctan,
    "exp": np.exp,
    "log": np.log,
    "log10": np.log10,
    "sqrt": np.sqrt,
    "abs": np.abs,
    "sign": np.sign,
}
POSITIVE_DOMAIN = {"log", "log10", "sqrt"}


def test_reference_covers_every_elementary_function():
    assert set(REFERENCE) == set(ELEMENTARY)


@pytest.mark.parametrize("mode", MODES)
@pytest.mark.parametrize("name", sorted(REFERENCE))
def test_elementary_function_values(name, mode):
    if name in POSITIVE_DOMAIN:
        u = np.array([0.05, 0.4, 0.95, 3.0, 17.0])
    else:
        u = np.array([-0.9, -0.25, 0.0, 0.4, 0.95])
    points = {"u": u, "v": np.linspace(-0.3, 0.3, 5)}
    check_values(f"{name}(u)", REFERENCE[name](u), mode, points=points)
    # an expression argument, and the function used as a factor
    arg = u / 2 + points["v"] / 2
    if name in POSITIVE_DOMAIN:
        arg = u + points["v"] ** 2
        check_values(f"2 {name}(u + v^2)", 2 * REFERENCE[name](arg), mode, points=points)
    else:
        check_values(f"2 {name}(u/2 + v/2)", 2 * REFERENCE[name](arg), mode, points=points)


@pytest.mark.parametrize("name", sorted(REFERENCE))
def test_elementary_function_needs_parentheses(name):
    with pytest.raises(SkeletonError, match="needs parentheses"):
        parse_expression(f"{name} x")


def test_elementary_function_of_constant_is_folded():
    check_values("exp(0) + sqrt(4) + abs(-3)", 6.0, "array")
    check_values("exp(0) + sqrt(4) + abs(-3)", 6.0, "scalar")


def test_scalar_mode_raises_on_domain_errors_array_mode_gives_nan():
    node = parse_expression("log(x)")
    scalar = compile_expression(node, {"x": 0}, mode="scalar")
    with pytest.raises(ValueError):
        scalar([-1.0])
    array = compile_expression(node, {"x": 0}, mode="array")
    with np.errstate(all="ignore"):
        out = array([np.array([-1.0, 1.0])])
    assert np.isnan(out[0])
    assert out[1] == 0.0


def test_scalar_mode_raises_on_division_by_zero():
    fn = compile_expression(parse_expression("1 / x"), {"x": 0}, mode="scalar")
    with pytest.raises(ZeroDivisionError):
        fn([0.0])


def test_compile_rejects_unknown_mode():
    with pytest.raises(ValueError, match="mode"):
        compile_expression(parse_expression("x"), {"x": 0}, mode="vector")


# --------------------------------------------------------------------------- bad input
def assert_points_at(err, index, position, text, *words):
    """The error names ``equations[index]``, the position, and draws a caret under it."""
    assert isinstance(err, SkeletonError)
    assert err.equation == index
    assert err.position == position
    assert err.text == text
    message = str(err)
    assert f"equations[{index}]" in message
    assert f"position {position}" in message
    lines = message.splitlines()
    assert lines[-2] == "    " + text
    assert lines[-1] == "    " + " " * position + "^"
    for word in words:
        assert word in message, f"{word!r} not in {message!r}"


def skeleton_error(bad, index=1):
    """Put ``bad`` at ``index`` of an otherwise valid list and return the error."""
    equations = [f"x{k}_dot = -x{k}" for k in range(index)] + [bad]
    with pytest.raises(SkeletonError) as info:
        Skeleton(equations)
    return info.value


def test_missing_equals_sign():
    text = "x1_dot x2 + 1"
    assert_points_at(skeleton_error(text), 1, len(text), text, "missing '='")


def test_missing_equals_sign_direct_parse_uses_given_index():
    text = "x1_dot - x2"
    with pytest.raises(SkeletonError) as info:
        parse_equation(text, 4)
    assert_points_at(info.value, 4, len(text), text, "missing '='")


def test_unclosed_parenthesis_points_at_the_opening_one():
    text = "x1_dot = (x2 + 1"
    assert_points_at(skeleton_error(text), 1, text.index("("), text, "never closed")


def test_unclosed_function_parenthesis_points_at_its_opening():
    text = "x1_dot = sin(x2 + cos(x1)"
    assert_points_at(skeleton_error(text), 1, text.index("("), text, "never closed")


def test_unopened_closing_parenthesis():
    text = "x1_dot = x2 + 1)"
    assert_points_at(skeleton_error(text), 1, text.index(")"), text, "')' without '('")


def test_unopened_closing_parenthesis_on_left_side():
    text = "x1_dot) = x2"
    assert_points_at(skeleton_error(text, 0), 0, text.index(")"), text, "')' without '('")


def test_unknown_function():
    text = "x1_dot = x2 + foo(x)"
    assert_points_at(skeleton_error(text), 1, text.index("foo"), text, "unknown function 'foo'")


def test_unknown_function_message_lists_known_ones():
    err = skeleton_error("x1_dot = bar(x1)")
    assert "tanh" in str(err)
    assert "f1, f2" in str(err)


def test_f_without_index():
    text = "x1_dot = -f(x1)"
    assert_points_at(skeleton_error(text), 1, text.index("f("), text, "'f' needs an index")


def test_curve_without_argument():
    text = "x1_dot = x2 - f1"
    assert_points_at(skeleton_error(text), 1, text.index("f1"), text, "f1", "needs an argument")


def test_curve_with_empty_argument():
    text = "x1_dot = f1()"
    assert_points_at(skeleton_error(text), 1, text.index("("), text, "f1() needs an argument")


def test_empty_parentheses():
    text = "x1_dot = x2 + ()"
    assert_points_at(skeleton_error(text), 1, text.index("("), text, "empty parentheses")


def test_empty_string():
    assert_points_at(skeleton_error("", 2), 2, 0, "", "empty equation")


def test_blank_string():
    assert_points_at(skeleton_error("   ", 0), 0, 0, "   ", "empty equation")


def test_nothing_after_equals():
    text = "x1_dot = "
    assert_points_at(skeleton_error(text), 1, text.index("="), text, "nothing after '='")


def test_dangling_operator():
    text = "x1_dot = x1 +"
    assert_points_at(skeleton_error(text), 1, len(text), text, "unexpected end")


def test_two_equals_signs():
    text = "x1_dot = x2 = x3"
    assert_points_at(skeleton_error(text), 1, text.rindex("="), text, "more than one '='")


def test_double_equals_is_not_comparison():
    text = "x1_dot == x2"
    with pytest.raises(SkeletonError) as info:
        parse_equation(text, 0)
    assert info.value.position == text.index("=") + 1


def test_number_following_a_factor():
    text = "x1_dot = x 2"
    err = skeleton_error(text)
    assert_points_at(err, 1, text.index("2"), text, "number cannot follow")


def test_number_following_a_parenthesis():
    text = "x1_dot = (x1 + 1) 3"
    assert_points_at(skeleton_error(text), 1, text.index("3"), text, "number cannot follow")


@pytest.mark.parametrize("func", ["sin", "f1", "tanh", "f12"])
def test_functions_take_one_argument(func):
    text = f"x1_dot = {func}(x1, x2)"
    assert_points_at(skeleton_error(text), 1, text.index(","), text, "exactly one argument")


def test_malformed_number():
    text = "x1_dot = 1.2.3 x1"
    assert_points_at(skeleton_error(text), 1, text.index(".3"), text, "malformed number")


def test_non_string_equation():
    with pytest.raises(SkeletonError) as info:
        Skeleton(["x1_dot = x2", 3.5, "x2_dot = x1"])
    err = info.value
    assert err.equation == 1
    assert "equations[1]" in str(err)
    assert "float" in str(err)


def test_non_string_equation_direct_parse():
    with pytest.raises(SkeletonError, match=r"equations\[5\].*string.*NoneType"):
        parse_equation(None, 5)


def test_single_string_instead_of_list():
    with pytest.raises(SkeletonError, match=r"list of strings.*not a single string"):
        Skeleton("x1_dot = -x1")


def test_empty_list():
    with pytest.raises(SkeletonError, match="no equations"):
        Skeleton([])


def test_not_iterable():
    with pytest.raises(SkeletonError, match="list of strings, got int"):
        Skeleton(7)


def test_skeleton_error_is_a_value_error():
    # sklearn's parameter validation and user code catch ValueError
    with pytest.raises(ValueError):
        Skeleton(["x1_dot = (x1"])


def test_parse_expression_rejects_equations_and_trailing_input():
    with pytest.raises(SkeletonError) as info:
        parse_expression("a1 x2 = 3", 2)
    assert info.value.equation == 2
    assert info.value.position == 6
    assert "terms[2]" in str(info.value)
    with pytest.raises(SkeletonError, match="empty expression"):
        parse_expression("")


# --------------------------------------------------------------------------- injection
INJECTIONS = [
    ("x1_dot = __import__('os').system('ls')", "__import__"),
    ("x1_dot = lambda x: x", "lambda"),
    ("x1_dot = x1.real", "."),
    ("x1_dot = x1[0]", "["),
    ('x1_dot = exec("import os")', '"'),
    ("x1_dot = exec(x1)", "exec"),
    ("x1_dot = eval(x1)", "eval"),
    ("x1_dot = open(x1)", "open"),
    ("x1_dot = 'x1'", "'"),
    ("x1_dot = x1; x2", ";"),
    ("x1_dot = `x1`", "`"),
    ("x1_dot = x1 if x2 else x3", "if"),
    ("x1_dot = __class__", "__class__"),
    ("x1_dot = x1 + __builtins__", "__builtins__"),
    ("__dict__ = x1", "__dict__"),
    ("x1_dot = x1 and x2", "and"),
    ("x1_dot = not x1", "not"),
    ("x1_dot = import_(x1)", "import_"),
    ("x1_dot = {x1}", "{"),
    ("x1_dot = x1 @ x2", "@"),
    ("x1_dot = x1 # comment", "#"),
    ("x1_dot = x1\\\nx2", "\\"),
    ("x1_dot = x1 % 2", "%"),
    ("x1_dot = x1 := 2", ":"),
    ("x1_dot = f1(x1).__globals__", "."),
    ("x1_dot = [x for x in x1]", "["),
]


@pytest.fixture
def no_side_effects(monkeypatch):
    """Record any import of a dangerous module and any os.system call."""
    calls = []
    real_import = builtins.__import__

    def spy_import(name, *args, **kwargs):
        if name.split(".")[0] in {"os", "subprocess", "shutil", "pathlib", "importlib"}:
            calls.append(("import", name))
        return real_import(name, *args, **kwargs)

    def spy_system(command):
        calls.append(("system", command))
        return 0

    monkeypatch.setattr(builtins, "__import__", spy_import)
    monkeypatch.setattr(os, "system", spy_system)
    return calls


def test_side_effect_spy_records(no_side_effects):
    # the spy of the injection tests does see an import and a shell command
    import os as reimported  # noqa: F401

    os.system("definitely-not-run")
    assert no_side_effects == [("import", "os"), ("system", "definitely-not-run")]


@pytest.mark.parametrize(("text", "culprit"), INJECTIONS)
def test_injection_is_rejected(text, culprit, no_side_effects):
    with pytest.raises(SkeletonError) as info:
        Skeleton(["x2_dot = x1", text])
    err = info.value
    assert err.equation == 1
    assert text[err.position :].startswith(culprit)
    assert no_side_effects == []


@pytest.mark.parametrize(("text", "culprit"), INJECTIONS)
def test_injection_is_rejected_as_bare_expression(text, culprit, no_side_effects):
    expression = text.split("=", 1)[1] if text.startswith("x1_dot =") else text
    with pytest.raises(SkeletonError):
        parse_expression(expression)
    assert no_side_effects == []


def test_injection_creates_no_file(tmp_path):
    sentinel = tmp_path / "sentinel"
    payloads = [
        f"x1_dot = __import__('pathlib').Path('{sentinel}').touch()",
        f"x1_dot = open('{sentinel}', 'w')",
        f"x1_dot = exec(\"open('{sentinel}', 'w')\")",
        f"x1_dot = eval(compile('open(\"{sentinel}\", \"w\")', 'x', 'eval'))",
        f"x1_dot = (lambda: open('{sentinel}', 'w'))()",
    ]
    for payload in payloads:
        with pytest.raises(SkeletonError):
            Skeleton([payload])
        with pytest.raises(SkeletonError):
            parse_equation(payload, 0)
    assert not sentinel.exists()


def test_injection_in_constraint_is_rejected(no_side_effects):
    with pytest.raises(SkeletonError):
        Skeleton(["x1_dot = f1(x1)"], ["__import__('os').system('ls')"])
    with pytest.raises(SkeletonError):
        Skeleton(["x1_dot = f1(x1)"], ["f1 odd; __import__('os')"])
    assert no_side_effects == []


def test_non_ascii_names_are_rejected():
    text = "x1_dot = \u03b1 x1"
    err = skeleton_error(text)
    assert_points_at(err, 1, text.index("\u03b1"), text, "ASCII")
