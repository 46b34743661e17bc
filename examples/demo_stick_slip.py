"""The PyCC paper's stick-slip oscillator, fitted with two backends.

x'' + delta x' + mu tanh(500 x') + alpha x + beta x^3 = cos(t)

The same data are fitted with the paper's three kinds of skeleton:
parametric (only a's), hybrid (a's and a curve) and functional (only
curves), with polynomial curves (PolyCCRegressor), and the functional and
hybrid skeletons again with neural curves (NeuralCCRegressor), the only
representation that follows the Coulomb step of the friction. Each fitted
model is printed, scored and simulated.
"""

import time

import numpy as np

from sklearn_pycc import NeuralCCRegressor, PolyCCRegressor, Skeleton, datasets


def rmse(a, b):
    return float(np.sqrt(np.mean((np.asarray(a) - np.asarray(b)) ** 2)))


frame, truth = datasets.make_stick_slip(return_truth=True)
X = frame[["t", "x1", "x2", "F_ext"]]
y = frame[["x1_dot", "x2_dot"]]
forcing = {"F_ext": truth.inputs["F_ext"]}

HYBRID = ["x1_dot = x2", "x2_dot = F_ext - f1(x2) - a4 x1 - a5 x1^3"]
FUNCTIONAL = ["x1_dot = x2", "x2_dot = F_ext - f1(x2) - f2(x1)"]
candidates = {
    "parametric, polynomial backend": (PolyCCRegressor, truth.parametric_equations, None, {}),
    "hybrid, polynomial backend": (PolyCCRegressor, HYBRID, ["f1 odd"], {"degree": 15}),
    "functional, polynomial backend": (PolyCCRegressor, FUNCTIONAL, ["f1 odd", "f2(0)=0"],
                                       {"degree": 15}),
    "hybrid, neural backend": (NeuralCCRegressor, HYBRID, ["f1 odd"], {"random_state": 0}),
    "functional, neural backend": (NeuralCCRegressor, FUNCTIONAL, ["f1 odd", "f2 odd"],
                                   {"random_state": 0}),
}

print(f"Data: the stick-slip oscillator of the PyCC paper, {len(frame)} samples, "
      f"t from {frame.t.iloc[0]:g} to {frame.t.iloc[-1]:g}")
for label, (backend, equations, constraints, options) in candidates.items():
    print("\n" + "=" * 78)
    print(f"{label} skeleton")
    print(Skeleton(equations, constraints))
    model = backend(equations=equations, constraints=constraints, **options)
    start = time.perf_counter()
    model.fit(X, y)
    fit_time = time.perf_counter() - start
    print(f"\nfitted in {1e3 * fit_time:.1f} ms; gauge: {model.gauge_ or 'nothing pinned'}")
    print("fitted model:")
    for line in model.equations(5):
        print("   ", line)
    if model.params_:
        errors = {k: abs(v - truth.params[k]) / abs(truth.params[k])
                  for k, v in model.params_.items() if k in truth.params}
        print("relative parameter errors:",
              ", ".join(f"{k} {v:.1e}" for k, v in errors.items()))
    for name, curve in model.cc_curves().items():
        if name in truth.functions:
            true = truth.functions[name](curve["x"])
            print(f"curve {name}: RMSE {rmse(curve[name], true):.2e} "
                  f"(spread of the true curve {np.std(true):.2f})")
    print(f"R^2 of the derivatives: {model.score(X, y):.8f}")
    start = time.perf_counter()
    sim = model.simulate(frame["t"], y0=truth.y0, inputs=forcing)
    sim_time = time.perf_counter() - start
    print(f"simulated in {1e3 * sim_time:.1f} ms; x(t) RMSE against the data: "
          f"{rmse(sim['x1'], frame['x1']):.2e}")
