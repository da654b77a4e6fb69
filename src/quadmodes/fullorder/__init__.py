"""Full-order nonlinear reference: total-Lagrangian dynamics of the whole FE model.

``M ẍ + f_d(x, ẋ) + f(x) = 0`` in the inertial frame, ``M = M_s ⊗ I₃`` constant
(:func:`quadmodes.fe.model.mass_matrix`), ``f`` the internal force of every element set
(membrane, pressure, ties, cable). SI units; states are ``(n, 3)`` arrays of vector DOFs.

Modules: :mod:`~quadmodes.fullorder.kinematics` (frames, reduced → full state map, per-sample
diagnostics, hub drive, centrifugal stretch), :mod:`~quadmodes.fullorder.integrator` (the time
stepping loop and its solution), with :mod:`~quadmodes.fullorder.setup` (what is computed once;
the run state), :mod:`~quadmodes.fullorder.step` (step force, damping force, predictor,
residual), :mod:`~quadmodes.fullorder.damping` (the damping basis: independent or retained
modes), :mod:`~quadmodes.fullorder.newton` (step Jacobian, reused factorisation,
backtracking), :mod:`~quadmodes.fullorder.sampling` (the sampled series) and
:mod:`~quadmodes.fullorder.checkpoint` (checkpoints, resume). Run cases, the Kane spin-up and
the wall-time estimate sit above, in :mod:`quadmodes.analysis.full_order_runs` (they set a run up
as :mod:`quadmodes.runs` does; nothing here imports the runs).

Choices (and why)
-----------------
* **Integrator: implicit midpoint with the energy–momentum stress average.** One step solves
  for x₁ with ``v½ = (x₁ − x₀)/Δt``, ``v₁ = 2v½ − v₀`` and
  ``M (v₁ − v₀)/Δt + f_step(x₀, x₁) + f_d = 0``. For the St Venant–Kirchhoff membranes and the
  Green-strain ties ``f_step = Dε(x½)ᵀ S((ε₀ + ε₁)/2)`` (Simo & Tarnow 1992); for the other sets
  (pressure, cable) ``f(x½)``. Both forms are equilibrated at x½ (zero net force, zero moment),
  so the discrete angular momentum ``H = Σ (x − p) × M v`` is conserved to the Newton tolerance;
  the averaged stress makes the elastic work of a step equal the energy change exactly (the
  constant-pressure term keeps a small cubic midpoint error that vanishes for rigid rotation).
  Why not the plain ``f(x½)``: the end-body ties are far stiffer than anything the step
  resolves (ωΔt ~ 10²); spinning at 41 Hz the plain midpoint pumps energy into them (the
  classical midpoint energy blow-up for nonlinear elastodynamics) and the Newton iteration fails
  after ≈ 50 steps at Δt = 0.5 ms and ≈ 160 at 0.25 ms. ``energy_momentum=False`` restores it.
* **Newton**: on the free DOFs with ``A = M + (Δt²/2) ∂f_step/∂x₁`` (sparse LU, nonsymmetric
  for the averaged stress), assembled in the body frame and applied through the current frame
  rotation (frame covariance ``J(𝒬z) = 𝒬 J(z) 𝒬ᵀ``), so one factorisation is reused across
  iterations *and* steps while successive corrections shrink at least twofold (modified Newton);
  refactored otherwise. With end-body ties (far stiffer than the step resolves) the free DOFs
  are split: the ties' block is renewed at every iteration and condensed onto their few DOFs,
  the rest is factorised once for many steps (:mod:`~quadmodes.fullorder.condensed`); when the
  ties touch too many DOFs for that (the flange-bonded ``paper-membrane``: 1,896), each
  correction is GMRES on the current matrix (applied matrix-free) preconditioned by a kept
  float32 factorisation (:mod:`~quadmodes.fullorder.krylov`; the step
  force and the matrix come from :mod:`~quadmodes.fullorder.kernels`, compiled by
  :mod:`~quadmodes.fullorder.jit` when numba is installed; docs/performance.md). Only the
  linear solves differ from full Newton (``full_newton=True``), not the equations or the
  stopping test. Backtracking on the residual norm for large corrections. Converged when
  the largest correction is below ``newton_tol × body size``. Predictor: the last two states'
  body frames extrapolated (exact for steady rotation; uses no velocity or acceleration, which
  carry the unresolved stiff components).
* **Damping**: ``f_d = W C Wᵀ v`` with ``W = Π M 𝒬 Φ_d``, ``C = diag 2ζω`` — Φ_d, by default
  (:mod:`~quadmodes.fullorder.damping`, "independent"), every prestressed FE mode below a
  cutoff (default 3 × max(spin, highest retained mode), degenerate pairs whole; computed once
  per model and cutoff and cached beside the reduced models), so the reference does not depend
  on the reduced basis it judges and damps the modes the reduced model leaves out; "retained"
  (the old reference, a baseline) uses the reduced model's Φ and C. Q the mass-weighted
  best-fit (mean-axes) rotation at x½, Π the M-orthogonal projector off the rigid motions
  Ψ(x½) about the CoM. So ``Wᵀv`` is the modal velocity of the elastic part of the motion, f_d
  has zero net force and moment (H is untouched) and ``v½ᵀ f_d ≥ 0``; ``E_d = Σ Δt v½ᵀ f_d``.
  Its rank-K contribution to the Newton matrix is left out (relative size ζωΔt ≲ 10⁻², a
  contraction factor). A clamped body uses the hub rotation and the velocity relative to the
  hub, without the projection (its independent basis: the clamped modes below the cutoff).
* **Steady rotation under the scheme.** The midpoint's steady rotation at Ω has end velocities
  ``κ Ω × r``, ``κ = tan(φ/2)/(φ/2)``, φ = ΩΔt (and, with ``f(x½)``, end configurations expanded
  by 1/cos(φ/2)). The initial state is mapped to that discrete form (otherwise every element
  gets a sudden O(φ²) strain and the ties ring at Nyquist), and the diagnostics are evaluated on
  the end states mapped back to the physical form (``rotation_map``). ``H_discrete`` is the
  scheme's exact invariant; ``H`` the mapped one (equal to O(φ²) fluctuations: ≈1e-8 at 10 Hz,
  Δt = 0.25 ms).
* **Clamped, hub-driven bodies** (ANCF cable clamped at the hub): the clamped components, in
  the hub frame, are prescribed (``x_c(t) = p + R_hub(t) X_c``) and the Newton solve runs on the
  free components in the hub frame at t₁ (this is where the clamp reaction acts).
* **Diagnostics** (same definitions as :mod:`quadmodes.rom.diagnostics`): H about the CoM over all
  vector DOFs (slopes included, M-weighted like the ROM's 𝒞 forms); T without the CoM
  translation; V = strain energy (with pressure potential) − that of the reference; the exact
  deformed inertia about the CoM, its minor axis tracked by continuity; spin rate = the
  *mean-axes* angular velocity (the ROM's ω, from ``𝒞(X, Rᵀv − ω × r) = 0``) on that axis; cone
  angle between H and the axis folded to [0, π/2]; modal coordinates by M-projection onto Φ in
  the best-fit frame, corrected for the quadratic modes by a fixed point.
* **Initial state from a reduced state** (:func:`initial_state_from_reduced`):
  ``x = p + R(X + Φs + ssG)``, ``v = R(ω × r + Φṡ + 2G(s, ṡ))``. For run cases
  (:func:`~quadmodes.analysis.full_order_runs.full_order_for_run`) the quasi-static
  centrifugal stretch outside the retained modes is added (``stretch=True``): the reduced state
  spins without it (at 41 Hz it is comparable to the inflation strain), which would otherwise
  start the full order with a violent breathing transient in modes the ROM does not have.
"""

from quadmodes.fullorder.integrator import FullOrderSolution, integrate_full_order
from quadmodes.fullorder.kinematics import (
    HubDrive,
    centrifugal_stretch,
    initial_state_from_reduced,
    kane_hub,
)
from quadmodes.fullorder.newton import FullOrderNewtonError
from quadmodes.fullorder.options import FullOrderOptions

__all__ = [
    "FullOrderNewtonError",
    "FullOrderOptions",
    "FullOrderSolution",
    "HubDrive",
    "centrifugal_stretch",
    "initial_state_from_reduced",
    "integrate_full_order",
    "kane_hub",
]
