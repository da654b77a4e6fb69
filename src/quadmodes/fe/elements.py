"""The element-set contract shared by every element type, and its base class.

An element set is a frozen dataclass holding its connectivity ``conn`` ``(ne, k)`` into the global
vector-DOF array and its (already SI) parameters. It implements, for a global state ``x`` ``(n, 3)``:

``energy(x) -> float``
    potential energy (J): strain energy, or ``-∫p dV`` for pressure.
``force(x) -> (ne, k, 3)``
    element internal force, the gradient of ``energy`` (N).
``stiffness(x) -> (ne, 3k, 3k)``
    element tangent stiffness, the Hessian of ``energy`` (N/m), symmetric.
``second_order(x, u, v) -> (ne, k, 3)``
    ``B(u, v) = ½ D²f(x)[u, v]``, the symmetric quadratic part of the internal force about ``x``.
``mass() -> (ne, k, k) | None``
    scalar consistent mass blocks ``M_s`` (kg); the 3-D mass is ``M_s ⊗ I_3``.

Forces follow the "internal" sign: equilibrium is ``Σ force = 0`` (pressure enters as the
gradient of its potential ``-pV``, so its ``force`` is ``-p ∇V``).

Extension point: the full-order step
------------------------------------
Every set also carries its part of the full order's implicit-midpoint step
(:mod:`quadmodes.fullorder.step`), which iterates over the sets and calls only these methods;
:class:`ElementSet` gives each a default, so a new set (a subclass implementing the five
methods above) integrates in the full order as it is:

``step_start(x0)``
    data of the step's start state reused by every iterate (default None).
``step_force(x0, x1, start=None) -> (ne, k, 3)``
    the energy–momentum step force of the step ``x₀ → x₁`` (N): a discrete gradient, its work
    ``Σ f·(x₁ − x₀)`` equals ``energy(x1) − energy(x0)`` (Simo & Tarnow's stress of the
    averaged strain for membranes, bars and quadratic-strain sets). Default: the plain
    midpoint ``force((x0 + x1)/2)`` (exact work for energies at most quadratic).
``step_block(x0, x1) -> (ne, 3k, 3k)``
    its Jacobian ``∂ step_force / ∂x1`` (N/m; not symmetric in general). Default
    ``½ stiffness((x0 + x1)/2)``.
``step_kernel(n, energy_momentum, jit=None)``
    the kernel of the compiled fast path (:mod:`quadmodes.fe.step_kernels`). Default: the
    assembled ``step_force``/``step_block`` (``energy_momentum``) or the plain midpoint.
"""

from __future__ import annotations

from abc import ABC, abstractmethod

import numpy as np

from quadmodes.fe.step_kernels import MidpointKernel, StepForceKernel, StepKernel


class ElementSet(ABC):
    """Base class of the element sets (module docstring). Subclasses are frozen dataclasses
    with a ``conn`` field; they implement the five abstract methods and may override the
    full-order step methods."""

    conn: np.ndarray

    @abstractmethod
    def energy(self, x: np.ndarray) -> float: ...

    @abstractmethod
    def force(self, x: np.ndarray) -> np.ndarray: ...

    @abstractmethod
    def stiffness(self, x: np.ndarray) -> np.ndarray: ...

    @abstractmethod
    def second_order(self, x: np.ndarray, u: np.ndarray, v: np.ndarray) -> np.ndarray: ...

    @abstractmethod
    def mass(self) -> np.ndarray | None: ...

    # ------------------------------------------------------------- full-order step (defaults)
    def step_start(self, x0: np.ndarray):
        """Start data of a step from x0 (n,3) for :meth:`step_force` (default: None)."""
        return None

    def step_force(self, x0: np.ndarray, x1: np.ndarray, start=None) -> np.ndarray:
        """Step force ``(ne, k, 3)`` (N) of the step x0 → x1 (n,3): the midpoint ``f(x½)``."""
        return self.force(0.5 * (x0 + x1))

    def step_block(self, x0: np.ndarray, x1: np.ndarray) -> np.ndarray:
        """``∂ step_force / ∂x1`` ``(ne, 3k, 3k)`` (N/m): ``½ K(x½)``."""
        return 0.5 * self.stiffness(0.5 * (x0 + x1))

    def step_kernel(self, n: int, energy_momentum: bool, jit=None) -> StepKernel:
        """Kernel of the fast step in a structure of ``n`` vector DOFs (``jit``: the compiled
        module :mod:`quadmodes.fullorder.jit`, or None): the set's own step methods with the
        energy–momentum average, else the plain midpoint."""
        return StepForceKernel(self, n) if energy_momentum else MidpointKernel(self, n)
