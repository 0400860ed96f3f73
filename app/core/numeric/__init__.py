"""The numeric twin of a robot: compiled functions, parameter values, algorithms, pinocchio.

- ``compile.numeric_function``: the one wrapper of ``sympy.numeric_function`` in the lab.
- ``model``: ``CompiledModel`` (``compiled_model(robot)``: every compiled function of one robot
  content, the only cache of compiled functions), ``Workspace`` (one user's parameter values), the
  algorithms as free functions over (model, workspace, q, ...), and ``NumericModel`` (the two in one
  object).
- ``terms``: ``ModelTerms`` (M, bias, inverse and forward dynamics at fixed values, from pinocchio
  where it applies) and ``TaskPoint`` (a point's p, J, J' q') for the simulator and controllers.
- ``twin``: ``PinocchioTwin`` and ``cross_check`` (symbolic against pinocchio).

>>> from app.core.robot import load_robot
>>> num = NumericModel(load_robot("planar_2r"))
>>> bool(np.allclose(num.M([0.1, 0.2]), num.M([0.1, 0.2]).T))
True
"""
import numpy as np

from ..robot import ParameterError  # noqa: F401 (re-exported)
from .compile import numeric_function
from .model import (CompiledModel, NumericModel, Workspace, bias, compiled_function, compiled_model,
                    coriolis_matrix, energy, forget_compiled, forward_dynamics, frames, friction, gravity,
                    inverse_dynamics, mass_matrix, model_key, spring)
from .terms import ModelTerms, TaskPoint, resolve_point
from .twin import CrossCheck, PinocchioTwin, cross_check, random_state

__all__ = ["numeric_function", "CompiledModel", "NumericModel", "Workspace", "compiled_function", "compiled_model",
           "model_key", "forget_compiled", "mass_matrix", "coriolis_matrix", "gravity", "spring", "friction",
           "bias", "inverse_dynamics", "forward_dynamics", "energy", "frames", "ModelTerms", "TaskPoint",
           "resolve_point", "PinocchioTwin", "CrossCheck", "cross_check", "random_state", "ParameterError"]
