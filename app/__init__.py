"""Robotics II Lab: robot dynamics and control, computed and shown step by step (docs/architecture.md)."""
from app.core.reproducible_sympy import install as _reproducible_factoring

_reproducible_factoring()
