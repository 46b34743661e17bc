"""The package's layout holds: no module reaches into another class's private methods."""

import ast
from pathlib import Path

import sklearn_pycc

PACKAGE = Path(sklearn_pycc.__file__).parent

#: (module, receiver.name): the few private names a module may use on another
#: object, each with its reason
ALLOWED = {
    # scikit-learn's own check of an estimator's hyperparameters, which its
    # meta-estimators call on the estimators they hold as well
    ("estimators/base.py", "estimator._validate_params"),
    # the hyperparameter table each estimator extends, scikit-learn's convention
    ("estimators/poly.py", "CCRegressor._parameter_constraints"),
    ("estimators/neural.py", "CCRegressor._parameter_constraints"),
    ("estimators/symbolic.py", "CCRegressor._parameter_constraints"),
    ("estimators/interpolated.py", "CCRegressor._parameter_constraints"),
}


def _defined_here(tree: ast.Module) -> set[str]:
    """Names of the functions, methods and attributes a module defines itself."""
    names = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.FunctionDef | ast.AsyncFunctionDef | ast.ClassDef):
            names.add(node.name)
        elif isinstance(node, ast.Attribute) and isinstance(node.ctx, ast.Store):
            names.add(node.attr)
        elif isinstance(node, ast.Name) and isinstance(node.ctx, ast.Store):
            names.add(node.id)
    return names


def _private_uses(source: str, relative: str) -> list[str]:
    tree = ast.parse(source, filename=relative)
    modules = {alias.asname or alias.name for node in ast.walk(tree)
               if isinstance(node, ast.Import | ast.ImportFrom) for alias in node.names}
    own = _defined_here(tree)
    found = []
    for node in ast.walk(tree):
        if not isinstance(node, ast.Attribute):
            continue
        name = node.attr
        if not name.startswith("_") or name.startswith("__"):
            continue
        receiver = node.value
        if isinstance(receiver, ast.Name) and receiver.id in ("self", "cls"):
            continue
        if isinstance(receiver, ast.Call) and isinstance(receiver.func, ast.Name) \
                and receiver.func.id == "super":
            continue
        if isinstance(receiver, ast.Name) and receiver.id in modules \
                and receiver.id in ("np", "numpy", "torch", "sympy", "pd", "scipy"):
            continue  # a library's own internals are its business
        if name in own:  # this module's own class or helper, used on one of its objects
            continue
        text = ast.unparse(receiver) + "." + name
        if (relative, text) not in ALLOWED:
            found.append(f"{relative}:{node.lineno}: {text}")
    return found


def test_no_module_calls_another_class_private_method():
    offenders = [use for path in sorted(PACKAGE.rglob("*.py"))
                 for use in _private_uses(path.read_text(), path.relative_to(PACKAGE).as_posix())]
    assert not offenders, "private names used across modules:\n" + "\n".join(offenders)


def test_the_check_sees_a_reach_into_another_class():
    source = ("class A:\n    def _mine(self):\n        return self._other()\n"
              "def use(model, a):\n    a._mine()\n    return model._set_fitted({})\n")
    assert _private_uses(source, "x.py") == ["x.py:6: model._set_fitted"]


def test_the_allow_list_has_no_stale_lines():
    used = set()
    for relative, text in ALLOWED:
        source = (PACKAGE / relative).read_text()
        if text in source:
            used.add((relative, text))
    assert used == ALLOWED
