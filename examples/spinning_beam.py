"""A spinning beam: the Campbell diagram of a cantilever on a spinning hub and a short
hub-driven spin-up, through the public API.

Physics checked: at rest the first bending frequency is the Euler-Bernoulli cantilever value
1.8751^2 sqrt(EI / (rho A L^4)); spinning stiffens the out-of-plane bending mode by Southwell's
coefficient, omega^2 = omega_0^2 + 1.193 Omega^2, and the in-plane one by 1.193 - 1
(rotating frame, no hub radius; the hub turns about z, the beam lies along x).

Run: ``python examples/spinning_beam.py``.
"""

from __future__ import annotations

import math

import numpy as np

import quadmodes as qm

#: Southwell coefficient of the first out-of-plane bending mode of a rotating cantilever.
SOUTHWELL_1 = 1.193


def cantilever_first_frequency(case) -> float:
    """First bending frequency (rad/s) of the Euler-Bernoulli cantilever of a beam case."""
    b = case.beam
    return 1.87510407**2 * math.sqrt(b.youngs_modulus * b.second_moment
                                     / (b.density * b.area * b.length**4))  # fmt: skip


def main(spin_max: str = "4 rad/s", spinup_duration: str = "3 s") -> dict:
    """Campbell diagram of kane-beam up to ``spin_max`` and a spin-up of ``spinup_duration``;
    returns the analytic and computed frequencies (rad/s) and the spin-up summary."""
    beam = qm.model_case("kane-beam")
    diagram = qm.campbell(beam, "0 rad/s", spin_max, points=5)
    omega0 = cantilever_first_frequency(beam)
    spin = float(diagram.spin[-1])
    freq = np.asarray(diagram.frequency)  # (ns, branches) rad/s, rotating frame
    out_of_plane = diagram.labels.index("bending z (0 nodes)")  # deflection along the hub axis
    in_plane = diagram.labels.index("bending y (0 nodes)")
    run = qm.run_case("kane-spinup", reduced={"modes": 2},
                      spinup={"omega_s": "2 rad/s", "ramp_time": "1.5 s",
                              "duration": spinup_duration, "samples": 301})  # fmt: skip
    result = qm.simulate(run)
    return {
        "omega0_analytic": omega0,
        "omega0": float(np.min(freq[0])),
        "spin": spin,
        "out_of_plane_analytic": math.sqrt(omega0**2 + SOUTHWELL_1 * spin**2),
        "out_of_plane": float(freq[-1, out_of_plane]),
        "in_plane_analytic": math.sqrt(omega0**2 + (SOUTHWELL_1 - 1.0) * spin**2),
        "in_plane": float(freq[-1, in_plane]),
        "labels": list(diagram.labels),
        "spinup": qm.summary(result),
    }


if __name__ == "__main__":
    r = main()
    print(f"first bending at rest: {r['omega0']:.4f} rad/s (Euler-Bernoulli {r['omega0_analytic']:.4f})")
    print(f"out of plane at {r['spin']:.2f} rad/s: {r['out_of_plane']:.4f} rad/s "
          f"(Southwell {r['out_of_plane_analytic']:.4f})")
    print("peak in-plane tip deflection (m):", r["spinup"]["peak_tip_deflection_m"])
