"""Print the reference's rotating-frame frequencies of the default rod (a steel rod 2 m long,
radius 1 cm, spun about its centre) against spin, and the size of each modelling term:
``cd tests && python -m reference``."""

import math

import numpy as np

from .closed_forms import free_free_beta_l
from .rotating_beam import rotating_free_beam

E, RHO, RADIUS, LENGTH = 210e9, 7850.0, 0.01, 2.0
AREA, SECOND = math.pi * RADIUS**2, math.pi * RADIUS**4 / 4
ROD = {"L": LENGTH, "EI_flap": E * SECOND, "EI_lag": E * SECOND, "EA": E * AREA,
       "rho_A": RHO * AREA, "rho_I_flap": RHO * SECOND, "rho_I_lag": RHO * SECOND}  # fmt: skip
OMEGA_1 = free_free_beta_l(1) ** 2 * math.sqrt(E * SECOND / (RHO * AREA)) / LENGTH**2


def _row(label: str, values: np.ndarray) -> str:
    return f"{label:>22} " + " ".join(f"{v:10.3f}" for v in values)


def main() -> None:
    print(f"first free-free bending frequency ω1 = {OMEGA_1:.4f} rad/s")
    for ratio in (0.0, 0.5, 1.0, 2.0, 3.0):
        omega = ratio * OMEGA_1
        out = rotating_free_beam(**ROD, Omega=omega, n_modes=4)
        print(f"Ω = {ratio:.1f} ω1 = {omega:.3f} rad/s")
        for key in ("flap_sym", "flap_anti", "lag_sym", "lag_anti"):
            print(_row(key + " [rad/s]", out[key]))
        variants = {
            "no stretch": {"stretch": False},
            "EA = inf": {"EA": math.inf},
            "no rotary inertia": {"rho_I_flap": 0.0, "rho_I_lag": 0.0},
        }
        for label, change in variants.items():
            other = rotating_free_beam(**{**ROD, **change}, Omega=omega, n_modes=4)
            for fam in ("flap", "lag"):
                rel = (out[fam] - other[fam]) / other[fam] * 100.0
                print(_row(f"{fam} vs {label} [%]", rel))


if __name__ == "__main__":
    main()
