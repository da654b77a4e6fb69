"""The element-set contract shared by every element type.

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
"""

from __future__ import annotations

from typing import Protocol

import numpy as np


class ElementSet(Protocol):
    conn: np.ndarray

    def energy(self, x: np.ndarray) -> float: ...

    def force(self, x: np.ndarray) -> np.ndarray: ...

    def stiffness(self, x: np.ndarray) -> np.ndarray: ...

    def second_order(self, x: np.ndarray, u: np.ndarray, v: np.ndarray) -> np.ndarray: ...

    def mass(self) -> np.ndarray | None: ...
