"""The published package's documented scripts, run with only the import changed.

Each document's python code blocks (``usage.rst``, the README's python
block, Examples 1 to 5) are read from ``../shared/upstream-pycc-docs``
(skipped without the folder), concatenated, and run after replacing
``import pycc`` by ``from sklearn_pycc import pycc``, nothing else. The
training budgets are lowered, and the trainings seeded, only through the
params the script hands to ``pycc`` (see :class:`CappedPycc`). After a run,
the curves and parameters each call learned are checked against the
document's own true functions and values, found in the script's namespace.
"""

import builtins
import re
import time
import types
from pathlib import Path

import matplotlib
import numpy as np
import pytest

from sklearn_pycc import pycc

matplotlib.use("Agg")
import matplotlib.pyplot as plt

FOLDER = Path(__file__).resolve().parents[2] / "shared" / "upstream-pycc-docs"
pytestmark = pytest.mark.skipif(not FOLDER.is_dir(),
                                reason="the published package's documents are absent")

#: the largest training budgets a document gets here (its own values when lower)
EPOCHS = 20             # L-BFGS epochs of about 20 iterations; the documents give 2000-10000
NITERATIONS = 5         # generations of each symbolic search (the documents give 100)
MAX_ITERATIONS = 2      # back-fitting rounds of SymbR (the documents give 15)
N_ITER_OUTER = 10       # iterations of the post-fine-tuning (Example 5 gives 100)
#: a learned curve's RMSE against the true one, as a share of the true curve's range
CURVE_TOLERANCE = 0.02
#: a learned parameter's relative error
PARAM_TOLERANCE = 0.01


# -- reading the documents ---------------------------------------------------------------------
def rst_python_blocks(text: str) -> list[str]:
    """The bodies of the ``.. code-block:: python`` directives of an rst text, dedented."""
    lines = text.splitlines()
    blocks, k = [], 0
    while k < len(lines):
        match = re.match(r"^(\s*)\.\. code-block::\s*python\s*$", lines[k])
        k += 1
        if not match:
            continue
        indent, body = len(match.group(1)), []
        while k < len(lines) and (not lines[k].strip()
                                  or len(lines[k]) - len(lines[k].lstrip()) > indent):
            body.append(lines[k])
            k += 1
        margin = min(len(line) - len(line.lstrip()) for line in body if line.strip())
        blocks.append("\n".join(line[margin:] for line in body))
    return blocks


def md_python_blocks(text: str) -> list[str]:
    """The bodies of the fenced ```` ```python ```` blocks of a markdown text."""
    return re.findall(r"^```python[ \t]*\n(.*?)^```", text, flags=re.S | re.M)


def script_of(name: str) -> str:
    """The document's python blocks, joined, with only the import changed."""
    text = (FOLDER / name).read_text(encoding="utf-8")
    blocks = md_python_blocks(text) if name.endswith(".md") else rst_python_blocks(text)
    assert blocks, f"{name} has no python code block"
    script = "\n\n".join(blocks)
    assert re.search(r"^import pycc\s*$", script, flags=re.M), f"{name} does not import pycc"
    return re.sub(r"^import pycc(\s*)$", r"from sklearn_pycc import pycc\1", script,
                  flags=re.M)


# -- running them -----------------------------------------------------------------------------
class CappedPycc:
    """Forwards to :mod:`sklearn_pycc.pycc`, lowering the budgets of the params it is given.

    Only copies of the script's params change: ``epochs``, the search's
    ``niterations``, ``max_iterations`` and ``n_iter_outer`` are capped, and
    neural and symbolic trainings are seeded (``random_state=0``) so that
    the accuracy checked afterwards does not change from run to run. Every
    call's results are kept in ``calls``.
    """

    def __init__(self) -> None:
        self.calls: list[tuple[str, str, object, tuple]] = []

    @staticmethod
    def _capped(method: str, params) -> dict:
        params = dict(params or {})
        if method == "NN":
            params["epochs"] = min(int(params.get("epochs", EPOCHS)), EPOCHS)
        if method in ("NN", "SymbR"):
            params.setdefault("random_state", 0)
        if method == "SymbR":
            params["max_iterations"] = min(int(params.get("max_iterations", 15)),
                                           MAX_ITERATIONS)
        if "pysr" in params or method == "SymbR":
            search = dict(params.get("pysr") or {})
            search["niterations"] = min(int(search.get("niterations", 100)), NITERATIONS)
            params["pysr"] = search
        if "n_iter_outer" in params:
            params["n_iter_outer"] = min(int(params["n_iter_outer"]), N_ITER_OUTER)
        return params

    def train(self, df, equations, method="NN", params=None):
        out = pycc.train(df, equations, method, self._capped(method, params))
        self.calls.append(("train", method, equations, out))
        return out

    def simulate(self, equations, method="Theoretical", params=None):
        out = pycc.simulate(equations, method, params)
        self.calls.append(("simulate", method, equations, out))
        return out

    def post_processing(self, equations, method="SymbR", params=None):
        params = dict(params or {})
        params.setdefault("random_state", 0)
        search = dict(params.get("pysr") or {})
        search["niterations"] = min(int(search.get("niterations", 100)), NITERATIONS)
        params["pysr"] = search
        out = pycc.post_processing(equations, method, params)
        self.calls.append(("post_processing", method, equations, out))
        return out


def run_document(name: str) -> tuple[dict, CappedPycc, float]:
    """Run the document's script; return its namespace, the calls it made and the time."""
    proxy = CappedPycc()
    package = types.SimpleNamespace(pycc=proxy)

    def import_(module, globals=None, locals=None, fromlist=(), level=0):
        if module == "sklearn_pycc" and fromlist and "pycc" in fromlist:
            return package
        return builtins.__import__(module, globals, locals, fromlist, level)

    namespace = {"__name__": "__main__",
                 "__builtins__": {**vars(builtins), "__import__": import_},
                 # Example 3 calls plt without importing it (the published script
                 # relies on an interactive session that has it): seeded here
                 "plt": plt}
    start = time.perf_counter()
    try:
        with np.errstate(all="ignore"):
            exec(compile(script_of(name), str(FOLDER / name), "exec"), namespace)
    finally:
        plt.close("all")
    return namespace, proxy, time.perf_counter() - start


# -- checks -----------------------------------------------------------------------------------
def check_curve(x, learned, truth, label: str) -> None:
    """RMSE of ``learned`` against ``truth`` on ``x`` within a share of the true range.

    A constant true curve (no range) is measured against its size instead.
    """
    expected = np.broadcast_to(np.asarray(truth(x), dtype=float), np.shape(x))
    scale = float(np.ptp(expected)) or float(np.max(np.abs(expected)))
    error = float(np.sqrt(np.mean((np.asarray(learned) - expected) ** 2)))
    assert error <= CURVE_TOLERANCE * scale, (
        f"{label}: RMSE {error:.3g} is {error / scale:.1%} of the true curve's range")


def check_evals(evals, truths, label: str) -> None:
    """Each curve of ``evals = [x_f1, f1, ...]`` against the true function in order."""
    assert len(evals) == 2 * len(truths), f"{label}: {len(evals) // 2} curves"
    for k, truth in enumerate(truths):
        check_curve(evals[2 * k], evals[2 * k + 1], truth, f"{label} f{k + 1}")


def check_params(coefs, truths: dict, label: str) -> None:
    for name, truth in truths.items():
        value = float(np.asarray(coefs[name]).item())
        assert value == pytest.approx(truth, rel=PARAM_TOLERANCE), (
            f"{label}: {name} = {value:.6g}, the truth is {truth:.6g}")


def trainings(proxy: CappedPycc, kind: str = "train"):
    return [(method, out) for call, method, _, out in proxy.calls if call == kind]


def check_stick_slip(namespace: dict, proxy: CappedPycc) -> None:
    """usage.rst, the README and Example 2: the NN-CC of the stick-slip oscillator."""
    truths = [namespace["F1_th"], namespace["F2_th"]]
    (method, (_, evals, coefs)), = trainings(proxy)
    assert method == "NN" and coefs == {}
    check_evals(evals, truths, "train(NN)")
    for method, (sol, _) in trainings(proxy, "simulate"):
        assert sol.success, f"simulate({method})"
    for _, (models_sr, evals_sr) in trainings(proxy, "post_processing"):
        check_evals(evals_sr, truths, "post_processing")
        assert set(models_sr) == {"f1", "f2"}


def check_example1(namespace: dict, proxy: CappedPycc) -> None:
    truth = namespace["F1"]
    done = trainings(proxy)
    assert [method for method, _ in done] == ["Poly", "SymbR", "NN"]
    for method, (_, evals, coefs) in done:
        assert coefs == {}
        check_evals(evals, [truth], f"train({method})")
    (_, (_, evals_sr)), = trainings(proxy, "post_processing")
    check_evals(evals_sr, [truth], "post_processing")


def check_example3(namespace: dict, proxy: CappedPycc) -> None:
    sigma, rho, beta = namespace["sigma"], namespace["rho"], namespace["beta"]
    done = trainings(proxy)
    assert [method for method, _ in done] == ["NN", "Poly", "SymbR"]
    for method, (_, evals, coefs) in done[:2]:  # the parametric Lorenz equations
        assert evals == []
        check_params(coefs, {"a1": sigma, "a2": rho, "a3": beta}, f"train({method})")
    _, (_, evals, coefs) = done[2]  # x1_dot = f1(x1) * (x2 - x1): f1 is sigma
    check_evals(evals, [lambda x: np.full_like(x, sigma)], "train(SymbR)")
    check_params(coefs, {"a2": rho, "a3": beta}, "train(SymbR)")


def check_example4(namespace: dict, proxy: CappedPycc) -> None:
    truths = [namespace["F1"], namespace["F2"]]
    done = trainings(proxy)
    assert [method for method, _ in done] == ["NN", "Poly", "SymbR"]
    for method, (_, evals, _) in done:
        check_evals(evals, truths, f"train({method})")
    for method, (sol, _) in trainings(proxy, "simulate"):
        assert sol.success, f"simulate({method})"


def check_example5(namespace: dict, proxy: CappedPycc) -> None:
    (_, (models, _, coefs)), = trainings(proxy)
    assert models.estimator.fit_mode_ == "simulation"
    values = {name: float(np.asarray(value).item()) for name, value in coefs.items()}
    truths = {"a1": namespace["delta"], "a2": namespace["mu"], "a4": namespace["alpha"],
              "a5": namespace["beta"]}
    check_params(values, truths, "train(Poly)")
    # a3 sits inside tanh(a3 x2) with a3 = 500: the tanh is a step at the data's
    # resolution, so any a3 steep enough fits as well; the composite curve is what the
    # data determine, and it is checked instead
    x = np.linspace(namespace["x2_data"].min(), namespace["x2_data"].max(), 200)
    learned = values["a1"] * x + values["a2"] * np.tanh(values["a3"] * x)
    check_curve(x, learned, namespace["F1"], "a1 x2 + a2 tanh(a3 x2)")
    (_, (sol, _)), = trainings(proxy, "simulate")[1:]
    assert sol.success
    gap = np.max(np.abs(sol.y[0] - namespace["x1_data"]))
    assert gap <= CURVE_TOLERANCE * np.ptp(namespace["x1_data"])


DOCUMENTS = {
    "usage.rst": check_stick_slip,
    "README.md": check_stick_slip,
    "Example1_training_function.rst": check_example1,
    "Example2_2nd_order_ODE.rst": check_stick_slip,
    "Example3_3rd_order_ODE.rst": check_example3,
    "Example4_1st_order_ODE_denominator.rst": check_example4,
    "Example5_automatic_outer_loop_fine_tuning_parametric.rst": check_example5,
}
#: documents run in the slow suite: the README's script and usage.rst train what Example 2
#: trains
SLOW = {"README.md", "usage.rst"}


# the documents give keys that mean nothing here: each call says so once, as users see it
@pytest.mark.filterwarnings("ignore:.*params that work differently here:UserWarning")
@pytest.mark.parametrize("name", [pytest.param(name, marks=pytest.mark.slow)
                                  if name in SLOW else name for name in DOCUMENTS])
def test_document_runs_and_learns(name):
    namespace, proxy, _ = run_document(name)
    DOCUMENTS[name](namespace, proxy)


def test_the_script_is_read_as_written():
    script = script_of("Example5_automatic_outer_loop_fine_tuning_parametric.rst")
    assert script.count("from sklearn_pycc import pycc") == 1
    assert not re.search(r"^import pycc", script, flags=re.M)
    assert "'fitting_forw_sim':True" in script  # the text itself, not a rewrite


def test_the_budgets_are_capped_on_copies():
    given = {"epochs": 2000, "pysr": {"niterations": 100}, "n_iter_outer": 100}
    capped = CappedPycc._capped("NN", given)
    assert capped["epochs"] == EPOCHS and capped["pysr"]["niterations"] == NITERATIONS
    assert capped["n_iter_outer"] == N_ITER_OUTER and capped["random_state"] == 0
    assert given == {"epochs": 2000, "pysr": {"niterations": 100}, "n_iter_outer": 100}
