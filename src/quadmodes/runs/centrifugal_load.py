"""The departure of the centrifugal load from a reduced model's, split by what the model holds.

With ω = Ω e + ω_t (Ω = ω·e about the model's reference axis e, ω_t ⊥ e) and the model's
ω_ref = Ω_ref e, the centrifugal acceleration per unit distance C(w) = wwᵀ − |w|² I departs by

    C(ω) − C(ω_ref) = (Ω² − Ω_ref²)(eeᵀ − I)          A: the spin's change
                    + Ω (e ω_tᵀ + ω_t eᵀ)              B: first order in the tilt
                    + ω_t ω_tᵀ − |ω_t|² I              C: second order in the tilt.

**What the model holds exactly.** Its modal equations, μ s̈ + (Γ(ω) + C) ṡ + (Λ − ωᵀJ2ω) s =
½ ωᵀJ1ω − A(s) ω̇, carry the centrifugal *load* of every ω: ½ ωᵀJ1_k ω = −Σ m φ_k·C(ω) r is the
work of the centrifugal force −m C(ω) r on mode k (J1 is the first variation of the inertia
tensor), A, B and C alike, and ωᵀJ2ω its change with the displacement. **What it holds fixed**
is the stiffness Λ about the prestress of ω_ref: the stiff degrees of freedom it condenses out
(a membrane's in-plane stretch, far above the spin) follow a change of the load quasi-statically,
and the stress they take changes the stiffness the retained modes see; the model has that
change only as far as the response lies in its modes. Bounding the whole stiffness by the
centrifugal prestress, the retained modes' squared frequencies are off by at most
‖ΔC‖₂ / Ω_ref² of the part of ΔC that lasts.

**Which part lasts.** In the body frame ω_t turns about e at the body-frame nutation frequency
λ_b = ν Ω (:func:`nutation_ratio`; ν = |I_a − I_t| / I_t for an axisymmetric body: 0.98 for
paper-41hz, 1 for a flat disc). A is static; B turns with ω_t at λ_b, zero mean; C is its mean
−|ω_t|² (½ P⊥ + eeᵀ) plus a part turning at 2λ_b of amplitude ½|ω_t|². The stiffness change of
B, ΔK_B ∝ cos(λ_b t + φ) of relative size ≤ Ω|ω_t|/Ω_ref² ≈ tan β, acting on the coning response
(forced at λ_b by B itself, through J1: the coning forcing the model is made to carry) gives
forces at 0 and 2λ_b only, so the response at λ_b, the power its damping dissipates and the cone
growth change at second order in B, ≈ tan²β; on a free oscillation at a rotating-frame frequency
it makes sidebands ±λ_b with no first-order shift of the mean frequency (a zero-mean
modulation), away from parametric resonance (a branch at λ_b / 2, held down by its damping for
a modulation this small). What B does at first order is the coning response itself, which the
modal-amplitude check judges. Hence the **quasi-static departure** is ‖A + C‖₂ / Ω_ref² =
max(|Ω² − Ω_ref²|, ||ω|² − Ω_ref²|, |ω_t|²) / Ω_ref² (eigenvalues −(Ω² − Ω_ref²) along ω_t,
−(|ω|² − Ω_ref²) along e × ω_t, −|ω_t|² along e): the spin's change, and the tilt's second-order
part, tan²β at a fixed spin, against sin β for the whole. It needs the tilt to turn in the body:
ν ≥ :data:`NUTATION_RATIO` (below it, a near-spherical inertia, B stands nearly still in the
body for many spin turns; about the intermediate axis, ν² < 0, the tilt grows instead of
turning): there B is quasi-static and the whole departure is judged. A planar body
(:func:`is_planar`) takes the in-plane block: B's is zero, C's e-row acts on r·e = 0.
"""

from __future__ import annotations

import math

import numpy as np

#: A body is planar (every mass in the plane normal to its reference axis: the free membrane
#: disc, a flat sail on a flat hub) when its second moment of mass along the axis is below this
#: fraction of the trace of its second-moment tensor (a flat spinning state: round-off).
PLANAR_TOLERANCE = 1e-9
#: Smallest body-frame nutation frequency, per unit spin, at which the tilt's first-order part
#: counts as turning in the body (module docstring): the tilt turns at least once every two
#: turns of the spin, so its 0 and 2λ_b products stand at least Ω/2 from the coning response at
#: λ_b. A regime boundary, not a derived threshold: the bodies of the project are at 0.98
#: (paper-41hz) to 1 (discs, sails); below it the whole departure (sin β) is judged.
NUTATION_RATIO = 0.5


def _matrix(v: np.ndarray) -> np.ndarray:
    """C(v) (…,3,3) = vvᵀ − |v|² I for v (…,3)."""
    return np.einsum("...a,...b->...ab", v, v) - np.einsum("...a,...a->...", v, v)[
        ..., None, None
    ] * np.eye(3)


def centrifugal_departure(omega: np.ndarray, omega_ref: np.ndarray) -> np.ndarray:
    """δ (k,) = ‖C(ω) − C(ω_ref)‖₂ / |ω_ref|² for ω (k,3) rad/s, C(w) = wwᵀ − |w|² I (the
    centrifugal acceleration per unit distance): the whole departure, A + B + C."""
    w = np.atleast_2d(np.asarray(omega, float))
    w0 = np.asarray(omega_ref, float)
    d = _matrix(w) - _matrix(w0)
    return np.abs(np.linalg.eigvalsh(d)).max(axis=-1) / float(w0 @ w0)


def _split(omega, omega_ref):
    """(ω (k,3), e (3,), Ω_ref, Ω = ω·e (k,), |ω_t|² (k,))."""
    w = np.atleast_2d(np.asarray(omega, float))
    spin_ref = float(np.linalg.norm(omega_ref))
    e = np.asarray(omega_ref, float) / spin_ref
    transverse = np.cross(w, e)  # |ω × e| = |ω_t|, without the cancellation of |ω|² − (ω·e)²
    return w, e, spin_ref, w @ e, np.einsum("ka,ka->k", transverse, transverse)


def spin_and_tilt(omega: np.ndarray, omega_ref: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The two parts of the departure for ω (k,3) rad/s from ω_ref = Ω_ref e: of the spin about
    e, |(ω·e)² / Ω_ref² − 1| (δ of a pure spin change), and of the direction, sin β = |ω × e| / |ω|
    (the whole δ of a pure tilt by β), each (k,)."""
    w, e, spin_ref, axial, _ = _split(omega, omega_ref)
    spin = np.abs(axial**2 / spin_ref**2 - 1.0)
    norm = np.linalg.norm(w, axis=1)
    tilt = np.linalg.norm(np.cross(w, e), axis=1) / np.where(norm > 0, norm, 1.0)
    return spin, tilt


def tilt_departure(omega: np.ndarray, omega_ref: np.ndarray) -> np.ndarray:
    """The tilt's quasi-static (second-order) part (k,): ‖ω_t ω_tᵀ − |ω_t|² I‖₂ / Ω_ref² =
    |ω_t|² / Ω_ref² (tan²β at a fixed spin about e) for ω (k,3) rad/s."""
    _, _, spin_ref, _, transverse = _split(omega, omega_ref)
    return transverse / spin_ref**2


def quasi_static_departure(omega: np.ndarray, omega_ref: np.ndarray) -> np.ndarray:
    """δ (k,) of the part of C(ω) − C(ω_ref) that lasts in the body frame (A + C of the module
    docstring): max(|Ω² − Ω_ref²|, ||ω|² − Ω_ref²|, |ω_t|²) / Ω_ref² for ω (k,3) rad/s."""
    _, _, spin_ref, axial, transverse = _split(omega, omega_ref)
    spin = (np.abs(axial) - spin_ref) * (np.abs(axial) + spin_ref)  # Ω² − Ω_ref², no cancellation
    return np.abs([spin, spin + transverse, transverse]).max(axis=0) / spin_ref**2


def plane_departure(omega: np.ndarray, omega_ref: np.ndarray) -> np.ndarray:
    """δ (k,) of a planar body: the departure of the in-plane block of C(ω), its only part that
    deforms the body. On the body's points (r·e = 0) the out-of-plane part of C(ω) r is
    (ω·e)(ω_t·r) e, the field of a rigid rotation about e × ω_t: it loads the rigid tilt, which
    the rigid-body equations carry exactly (a free flat body nutates at exactly Ω, its tilt a
    rotating-frame mode there), not the membrane. The in-plane block has the eigenvalues −(ω·e)²
    (along ω's in-plane part) and −|ω|² (across it), so δ = max(|(ω·e)² − Ω²|, ||ω|² − Ω²|) / Ω²:
    second order in the tilt β (tan²β at a fixed spin about e), :func:`quasi_static_departure`
    without its e-row."""
    w, _, spin_ref, axial, _ = _split(omega, omega_ref)
    whole = np.abs(np.einsum("ka,ka->k", w, w) / spin_ref**2 - 1.0)
    return np.maximum(np.abs(axial**2 / spin_ref**2 - 1.0), whole)


def _axis_moments(system) -> tuple[float, float, float]:
    """(I_e, I_1, I_2) kg m²: the body's moment of inertia about its reference axis e and the
    principal moments of J0 across it."""
    w_ref = np.asarray(system.reference_omega, float)
    e = w_ref / np.linalg.norm(w_ref)
    j0 = np.asarray(system.J0, float)
    basis = np.linalg.svd(np.eye(3) - np.outer(e, e))[0][:, :2]  # an orthonormal basis of e⊥
    i1, i2 = np.linalg.eigvalsh(basis.T @ j0 @ basis)
    return float(e @ j0 @ e), float(i1), float(i2)


def nutation_ratio(system) -> float:
    """ν = λ_b / Ω (1): the rigid body's nutation frequency in its body frame per unit spin about
    its reference axis, ν² = (I_e − I_1)(I_e − I_2) / (I_1 I_2) (torque-free spin about a
    principal axis; NaN about the intermediate axis, where the tilt grows instead of turning)."""
    i_e, i1, i2 = _axis_moments(system)
    square = (i_e - i1) * (i_e - i2) / (i1 * i2)
    return math.sqrt(square) if square >= 0 else math.nan


def is_planar(system) -> bool:
    """The body's mass lies in the plane normal to its reference angular velocity: its second
    moment ``Σ m (r·e)²`` = ``eᵀ(½ tr J0 − J0)e`` within :data:`PLANAR_TOLERANCE` of the trace."""
    w_ref = np.asarray(system.reference_omega, float)
    if not np.any(w_ref):
        return False
    e = w_ref / np.linalg.norm(w_ref)
    j0 = np.asarray(system.J0, float)
    second = 0.5 * np.trace(j0) * np.eye(3) - j0
    return float(e @ second @ e) <= PLANAR_TOLERANCE * float(np.trace(second))


def tilt_turns(system) -> bool:
    """The tilt's first-order part turns in the body (ν ≥ :data:`NUTATION_RATIO`), so only its
    second-order part is quasi-static."""
    return bool(nutation_ratio(system) >= NUTATION_RATIO)


def load_departure_about(system, omega: np.ndarray, omega_ref: np.ndarray) -> np.ndarray:
    """δ (k,) of the angular velocities ``omega`` (k,3) rad/s against ``omega_ref`` (the model's,
    or a spin-family member's about the same axis): :func:`plane_departure` for a planar body,
    :func:`quasi_static_departure` where the tilt turns in the body, else the whole
    :func:`centrifugal_departure`."""
    if is_planar(system):
        return plane_departure(omega, omega_ref)
    if tilt_turns(system):
        return quasi_static_departure(omega, omega_ref)
    return centrifugal_departure(omega, omega_ref)


def load_departure(system, omega: np.ndarray) -> np.ndarray:
    """δ (k,) of the path's angular velocities ``omega`` (k,3) rad/s against the model's
    reference (:func:`load_departure_about`)."""
    return load_departure_about(system, omega, np.asarray(system.reference_omega, float))


def departure_kind(system) -> str:
    """How :func:`load_departure` takes δ, for the results' description."""
    if is_planar(system):
        return "its in-plane block: a planar body"
    if tilt_turns(system):
        return ("its quasi-static part: the spin's change and the tilt's second-order part; "
                "the tilt's first-order part turns in the body, the coning forcing")
    return "the whole departure: the tilt does not turn in the body"
