"""Research prototypes: unstable, they may change or vanish without notice, and they are not
part of the public API. They are kept tested (tests/test_experimental_*.py) and are reached from
tests and the studies in ``benchmarks/studies/`` only: no product module of quadmodes imports
this package (tests/test_layout.py checks it).

* :mod:`~quadmodes.experimental.candidate_potentials`: candidate reduced potentials (Q, Q4, the
  exact manifold energy QE, W_red condensed on the quadratic modes) against the FE model's
  condensed energy W_c of :mod:`quadmodes.rom.manifold_energy` (docs/potentials.md);
* :mod:`~quadmodes.experimental.condensed_potential`: the wrinkled structure's potential
  condensed on a snapshot-augmented basis (a ``ReducedSystem.nonlinear_potential``);
* :mod:`~quadmodes.experimental.augmented_basis`: snapshot coordinates with mass;
* :mod:`~quadmodes.experimental.manifold_lagrangian`: the consistent fourth-order Lagrangian (the
  exact kinetic energy of the quadratic manifold, Q4's potential, the full order's damping on the
  manifold velocity), integrated by scipy (docs/path-validity.md).
"""
