"""The seed paper's illustrative example (NN-CC workflow) against the published package's API.

Only the import differs from the paper's listings: ``from sklearn_pycc import
pycc``. It generates the stick-slip data, identifies f1 and f2 with neural
networks, simulates the identified model, turns the curves into expressions
(post-SR) and simulates those through interpolated tables; the figures
(curves.png, post_sr.png, trajectories.png) go to the output folder. Run::

    python examples/paper_workflow.py [output-folder]
"""

import sys
from pathlib import Path

import matplotlib

matplotlib.use("Agg")

import matplotlib.pyplot as plt
import numpy as np
import pandas as pd

from sklearn_pycc import pycc

out = Path(sys.argv[1] if len(sys.argv) > 1 else "paper-output")
out.mkdir(parents=True, exist_ok=True)

# data generation with method='Theoretical'
alpha = 1.0
beta = 0.2
delta = 0.1
Omega = 1.0
y0 = [0.0, 0.0]
t_span = (0, 20)
t_eval = np.linspace(*t_span, 1000)


def F1_th(x_dot):
    return delta * x_dot + 0.5 * np.tanh(500 * x_dot)


def F2_th(x):
    return alpha * x + beta * x**3


def F_ext(t):
    return np.cos(Omega * t)


eqs_th = ['x1_dot = x2', 'x2_dot = F_ext - f1(x2) - f2(x1)']
params_th = {'t_span': t_span, 'y0': y0, 't_eval': t_eval, 'method': 'LSODA',
             'local_funcs': {'f1': F1_th, 'f2': F2_th, 'F_ext': F_ext}}
sol, derivatives = pycc.simulate(eqs_th, method='Theoretical', params=params_th)
df = pd.DataFrame({'x1': sol.y[0], 'x2': sol.y[1], 'x1_dot': derivatives[0],
                   'x2_dot': derivatives[1], 'F_ext': F_ext(sol.t)})

# NN-CC identification
eqs = ['x1_dot = x2', 'x2_dot = F_ext - f1(x2) - f2(x1)']
constraints = [{'constraint': 'f2(0)=0'}, {'constraint': 'f1 odd'}, {'constraint': 'f2 odd'}]
params_nn = {'neurons': 100, 'layers': 3, 'epochs': 30, 'device': 'cpu',
             'constraints': constraints}
models, evals, obtained_coefs = pycc.train(df, eqs, method='NN', params=params_nn)
x_f1_cc, f1_cc, x_f2_cc, f2_cc = evals
fig, ax = plt.subplots(1, 2, figsize=(12, 5))
ax[0].plot(x_f1_cc, f1_cc, label='$f_1$ learned NN-CC')
ax[0].plot(x_f1_cc, F1_th(x_f1_cc), '--', label='$f_1$ theory')
ax[1].plot(x_f2_cc, f2_cc, label='$f_2$ learned NN-CC')
ax[1].plot(x_f2_cc, F2_th(x_f2_cc), '--', label='$f_2$ theory')
for a in ax:
    a.legend()
fig.savefig(out / "curves.png", dpi=100)

# simulation of the identified model
params_nn_simul = {'models': models, 'obtained_coefs': obtained_coefs,
                   'local_funcs': {'F_ext': F_ext}, 't_span': t_span, 'y0': y0,
                   't_eval': t_eval, 'method': 'LSODA', 'atol': 1e-8, 'rtol': 1e-6,
                   'check_nan': True}
sim, _ = pycc.simulate(eqs, method='NN', params=params_nn_simul)

# post-SR of the curves, simulated through PCHIP tables
post_process_params = {'evals': evals, 'plot': True, 'n_eval': 200,
                       'constraints': ['f1 odd', 'f2 odd'],
                       'pysr': {'niterations': 100, 'populations': 20, 'maxsize': 20,
                                'binary_operators': ['+', '*', '-'],
                                'unary_operators': ['tanh', 'sin', 'cos']}}
models_sr, evals_sr = pycc.post_processing(eqs, method='SymbR', params=post_process_params)
models_sr.figure.savefig(out / "post_sr.png", dpi=100)
params_sim_interp = {'evals': evals_sr, 'obtained_coefs': obtained_coefs,
                     'local_funcs': {'F_ext': F_ext}, 'interp_method': 'pchip',
                     't_span': t_span, 'y0': y0, 't_eval': t_eval}
interp, _ = pycc.simulate(eqs, method='Interp', params=params_sim_interp)

fig, ax = plt.subplots(figsize=(8, 4))
ax.plot(sol.t, sol.y[0], label='x(t) th')
ax.plot(sim.t, sim.y[0], '--', label='x(t) simulated with NN method')
ax.plot(interp.t, interp.y[0], ':', label='x(t) post-SR, pchip tables')
ax.set_xlabel('t')
ax.set_ylabel('x(t)')
ax.legend()
fig.savefig(out / "trajectories.png", dpi=100)

for name in ("f1", "f2"):
    print(f"{name}(x) = {models_sr[name]['expr']}")
for label, result in (("NN", sim), ("post-SR, PCHIP tables", interp)):
    error = np.max(np.abs(result.y[0] - sol.y[0]))
    print(f"max |x1 - x1 data| simulated with {label}: {error:.2e}")
# the estimator behind the functional API, to go on with scikit-learn
print(models.estimator)
