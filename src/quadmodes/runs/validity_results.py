"""The validity of a run's reduced model in its files: the ``results.nc`` attributes of a
:class:`quadmodes.runs.validity.Validity` (at the start: spin, initial deformation, slack onset)
and the JSON-ready fields read back from them (the path's validity is
:mod:`quadmodes.runs.path_results`)."""

from __future__ import annotations

import math

import xarray as xr


def _float(x) -> float | None:
    """``x`` as a float, None when it is not finite (JSON has no NaN)."""
    x = float(x)
    return x if math.isfinite(x) else None


def validity_attrs(validity) -> dict:
    """results.nc attributes of a :class:`quadmodes.runs.validity.Validity` (empty if None):
    ``valid`` (1/0), ``rotating_stiffness_min_eigenvalue`` (s-2, at the run's spin),
    ``validity_spin_rate`` (rad/s) and ``validity_lost_at_spin_rate`` (rad/s; NaN if never)."""
    if validity is None:
        return {}
    lost = validity.lost_at
    return {
        "valid": int(validity.valid),
        "valid_spin": int(validity.spin_valid),  # the two checks: spin, initial deformation
        "valid_initial_deformation": int(validity.initial_deformation_valid),
        "rotating_stiffness_min_eigenvalue": float(validity.min_eigenvalue),
        "rotating_stiffness_min_eigenvalue_units": "s^-2",
        "validity_spin_rate": float(validity.spin_rate),
        "validity_lost_at_spin_rate": float("nan") if lost is None else float(lost),
        "validity_message": validity.message(),
        "initial_deformation_energy_reduced": float(validity.deformation_energy_reduced),
        "initial_deformation_energy_condensed": float(validity.deformation_energy_condensed),
        "initial_deformation_energy_units": "J",
        # where a membrane element taut at the reference first loses tension along the initial
        # deformation (exact strain of the manifold displacement), and the reference's slack area
        "slack_onset_fraction": float(validity.slack_onset_fraction),
        "slack_onset_amplitude": float(validity.slack_onset_amplitude),
        "slack_onset_amplitude_units": "m",
        "slack_membrane_fraction": float(validity.slack_fraction),
        "reference_slack_fraction": float(validity.reference_slack_fraction),
    }


def validity_summary(ds: xr.Dataset) -> dict:
    """JSON-ready validity fields read back from the attributes of a results dataset."""
    if "valid" not in ds.attrs:
        return {}
    lost = _float(ds.attrs.get("validity_lost_at_spin_rate", float("nan")))
    checked = math.isfinite(float(ds.attrs.get("initial_deformation_energy_reduced", math.nan)))
    return {
        "valid": bool(int(ds.attrs["valid"])),
        "valid_spin": bool(int(ds.attrs.get("valid_spin", ds.attrs["valid"]))),
        "valid_initial_deformation": bool(int(ds.attrs.get("valid_initial_deformation", 1)))
        if checked else None,  # None: no initial deformation to check
        "rotating_stiffness_min_eigenvalue": _float(
            ds.attrs.get("rotating_stiffness_min_eigenvalue", float("nan"))
        ),
        "validity": {
            "valid": bool(int(ds.attrs["valid"])),
            "rotating_stiffness_min_eigenvalue": _float(
                ds.attrs.get("rotating_stiffness_min_eigenvalue", float("nan"))
            ),
            "rotating_stiffness_min_eigenvalue_units": "s^-2",
            "spin_rate_rad_s": _float(ds.attrs.get("validity_spin_rate", float("nan"))),
            "lost_at_spin_rate_rad_s": lost,
            "message": str(ds.attrs.get("validity_message", "")),
            # the initial deformation beside the FE model's condensed energy (J; null if unchecked)
            "initial_deformation_energy_reduced_J": _float(
                ds.attrs.get("initial_deformation_energy_reduced", float("nan"))
            ),
            "initial_deformation_energy_condensed_J": _float(
                ds.attrs.get("initial_deformation_energy_condensed", float("nan"))
            ),
            "slack_onset_fraction_of_initial_deformation": _float(
                ds.attrs.get("slack_onset_fraction", float("nan"))
            ),
            "slack_onset_amplitude_m": _float(ds.attrs.get("slack_onset_amplitude", float("nan"))),
            "slack_membrane_fraction_at_initial_deformation": _float(
                ds.attrs.get("slack_membrane_fraction", float("nan"))
            ),
            "reference_slack_fraction": _float(ds.attrs.get("reference_slack_fraction", math.nan)),
        },
    }
