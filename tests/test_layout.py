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


# -- imports and sizes -----------------------------------------------------------------
#: the longest function body (its docstring aside) a module may hold
MAX_BODY_LINES = 150


def _module_name(path: Path) -> str:
    parts = list(path.relative_to(PACKAGE.parent).with_suffix("").parts)
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def _imports(path: Path, name: str) -> list[tuple[str, str]]:
    """``(module, imported name)`` of each of the package's imports, deferred ones too."""
    tree = ast.parse(path.read_text(), filename=str(path))
    package = name.split(".") if path.name == "__init__.py" else name.split(".")[:-1]
    found = []
    for node in ast.walk(tree):
        if not isinstance(node, ast.ImportFrom):
            continue
        if node.level:
            base = package[:len(package) - (node.level - 1)]
            module = ".".join(base + ([node.module] if node.module else []))
        else:
            module = node.module or ""
        if module.split(".")[0] == "sklearn_pycc":
            found += [(module, alias.name) for alias in node.names]
    return found


def _graph() -> dict[str, set[str]]:
    modules = {_module_name(p): p for p in PACKAGE.rglob("*.py")}
    edges = {}
    for name, path in modules.items():
        targets = set()
        for module, imported in _imports(path, name):
            if f"{module}.{imported}" in modules:  # a module imported from its package
                targets.add(f"{module}.{imported}")
            elif module in modules:
                targets.add(module)
        edges[name] = targets - {name}
    return edges


def _circles(edges: dict[str, set[str]]) -> list[list[str]]:
    """The strongly connected groups of more than one module (Tarjan's algorithm)."""
    index, low, stack, on_stack, found = {}, {}, [], set(), []

    def visit(v):
        index[v] = low[v] = len(index)
        stack.append(v)
        on_stack.add(v)
        for w in edges.get(v, ()):
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on_stack:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            group = []
            while True:
                w = stack.pop()
                on_stack.discard(w)
                group.append(w)
                if w == v:
                    break
            if len(group) > 1:
                found.append(sorted(group))

    for v in sorted(edges):
        if v not in index:
            visit(v)
    return found


def test_no_modules_import_each_other():
    assert _circles(_graph()) == []


def test_the_circle_check_sees_a_circle():
    edges = {"a": {"b"}, "b": {"c"}, "c": {"a"}, "d": {"a"}}
    assert _circles(edges) == [["a", "b", "c"]]


def test_no_private_name_is_imported_from_another_module():
    offenders = [f"{_module_name(path)} imports {module}.{imported}"
                 for path in sorted(PACKAGE.rglob("*.py"))
                 for module, imported in _imports(path, _module_name(path))
                 if imported.startswith("_") and not imported.startswith("__")]
    assert not offenders, "\n".join(offenders)


def _body_lines(function: ast.FunctionDef) -> int:
    lines = function.end_lineno - function.lineno + 1
    first = function.body[0]
    if isinstance(first, ast.Expr) and isinstance(first.value, ast.Constant) \
            and isinstance(first.value.value, str):
        lines -= first.end_lineno - first.lineno + 1
    return lines


def _functions():
    """``(path, function)`` for every function and method of the package."""
    for path in sorted(PACKAGE.rglob("*.py")):
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, ast.FunctionDef | ast.AsyncFunctionDef):
                yield path.relative_to(PACKAGE), node


def test_no_function_is_longer_than_a_reader_can_follow():
    long = [f"{path}:{node.lineno} {node.name} ({_body_lines(node)} lines)"
            for path, node in _functions() if _body_lines(node) > MAX_BODY_LINES]
    assert not long, "\n".join(long)


#: the package's layers, lowest first: a module imports only from its own layer and those
#: below it (the root's ``__init__`` gathers every layer's public names)
LAYERS = [
    ("_utils",),
    ("exceptions",),
    ("simulation",),
    ("skeleton",),
    ("plotting", "effects", "quantities"),
    ("measurements",),
    ("fitting",),
    ("backends",),
    ("estimators",),
    ("model_selection",),
    ("diagnostics",),
    ("datasets", "pycc"),
]


def _layer(module: str) -> int | None:
    parts = module.split(".")
    top = parts[1] if len(parts) > 1 else None
    return next((i for i, names in enumerate(LAYERS) if top in names), None)


def test_each_layer_imports_only_the_layers_below_it():
    upward = []
    for module, targets in _graph().items():
        here = _layer(module)
        if here is None:  # the package's root gathers the public names
            continue
        upward += [f"{module} imports {target}" for target in targets
                   if _layer(target) is not None and _layer(target) > here]
    assert not upward, "\n".join(upward)


def test_every_part_of_the_package_has_its_layer():
    tops = {path.relative_to(PACKAGE).parts[0].removesuffix(".py")
            for path in PACKAGE.iterdir() if path.suffix == ".py" or path.is_dir()}
    tops -= {"__init__", "__pycache__"}
    assert tops == {name for names in LAYERS for name in names}


#: the most parameters a function takes by position (``self`` aside); the rest by keyword
MAX_POSITIONAL = 5


def _positional(function: ast.FunctionDef) -> int:
    names = [a.arg for a in function.args.posonlyargs + function.args.args]
    return len(names) - (1 if names and names[0] in ("self", "cls") else 0)


def test_a_long_parameter_list_is_passed_by_keyword():
    long = [f"{path}:{node.lineno} {node.name} ({_positional(node)})"
            for path, node in _functions() if _positional(node) > MAX_POSITIONAL]
    assert not long, "\n".join(long)
