"""Benchmark systems with known characteristic curves, simulated on demand.

Each ``make_*`` function simulates one system of ordinary differential
equations whose hidden curves are known, and returns a
:class:`pandas.DataFrame` with the columns ``t``, the states, the inputs and
the exact (noise-free) derivatives ``NAME_dot``, evaluated from the
right-hand side on the trajectory. Gaussian measurement noise may be added
at a given signal-to-noise ratio to chosen columns.

With ``return_truth=True`` the functions also return a
:class:`~sklearn.utils.Bunch` describing the ground truth: the functional
skeleton, the true curves, the true parameters, the input signals and the
initial state.

The truth also names what a hypothesis loop should find: ``base_equations``
is the linear skeleton the loop starts from and ``hidden`` the catalogue
names (:mod:`sklearn_pycc.effects`) of the effects it lacks.

The systems follow the families of the method's papers:

- :func:`make_stick_slip`: the seed paper's Duffing oscillator with
  stick-slip friction;
- :func:`make_duffing`: a forced chaotic Duffing oscillator;
- :func:`make_van_der_pol`: a forced van der Pol oscillator in Liénard form;
- :func:`make_first_order`: a first-order nonlinear RC or RL circuit,
  written unsolved for the derivative;
- :func:`make_two_dof`: two oscillators joined by a nonlinear spring;
- :func:`make_oscillator`: a linear oscillator with chosen effects of the
  catalogue hidden in it.

and records as a laboratory hands them over (positions only, quantised,
sampled in closed loop, few samples per period, dropped samples):

- :func:`make_positioning_axis`: a positioning axis under a sampled PD
  controller, read by an incremental encoder;
- :func:`make_resonator`: a lightly damped hardening oscillator driven by a
  multisine and sampled at about ten samples per period;

and records of plants and buildings, with states no sensor reads:

- :func:`make_two_tanks`: a cascade of two tanks, the upper level unmeasured;
- :func:`make_heated_tank`: a stirred tank heated through a pipe, its power
  read a transport delay late;
- :func:`make_rooms`: rooms in a row heated through their walls, the walls'
  temperatures unmeasured, time in hours, minutes or seconds.
"""

from ._buildings import make_rooms
from ._lab_records import make_pendulum, make_positioning_axis, make_resonator
from ._oscillators import (  # and the table make_oscillator's docs point to
    HIDDEN_DEFAULTS as HIDDEN_DEFAULTS,
)
from ._oscillators import (
    make_duffing,
    make_experiments,
    make_first_order,
    make_oscillator,
    make_stick_slip,
    make_two_dof,
    make_van_der_pol,
)
from ._process_records import make_heated_tank, make_two_tanks
from ._sensor_noise import add_sensor_noise

__all__ = [
    "add_sensor_noise",
    "make_duffing",
    "make_experiments",
    "make_first_order",
    "make_heated_tank",
    "make_oscillator",
    "make_pendulum",
    "make_positioning_axis",
    "make_resonator",
    "make_rooms",
    "make_stick_slip",
    "make_two_dof",
    "make_two_tanks",
    "make_van_der_pol",
]
