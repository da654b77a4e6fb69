"""The meaning of every field of the case tables, in the paper's notation where it has one.

:data:`TABLE_DOCS` says what each table is, :data:`FIELD_DOCS` what each field means, keyed by
the table class name and the field name. The reference (:mod:`quadmodes.case.reference`) and the
JSON Schema read them; ``tests/test_case_reference.py`` fails when a field has none or an entry
names a field that no longer exists. Units, defaults, allowed values and examples come from the
fields themselves (:mod:`quadmodes.case.fields`), not from here.

Symbols: the seed paper's ρ (density), Ω (spin rate), s_m (modal coordinates) and u^m (modes);
E, ν, t, p, κ, ζ, θ are the usual Young's modulus, Poisson's ratio, thickness, pressure, gas-law
exponent, damping ratio and cone angle. The body axis of a membrane of revolution is z; its
front pole is at z = 0, its rear pole at z = length.
"""

from __future__ import annotations

TABLE_DOCS: dict[str, str] = {
    "Case": "A model case: the structure (membrane, beam or spacecraft) and its modes.",
    "Geometry": "The membrane's stress-free surface: a body of revolution about z, or a mesh file.",
    "Mesh": "How the surface is triangulated.",
    "Material": "The membrane's isotropic material (St Venant–Kirchhoff, or its tension-field "
    "relaxation).",
    "Pressure": "The inflation pressure and how the inflation follows it.",
    "EndBody": "A rigid body at a pole (a payload, a tip mass, an end fitting); repeat the "
    "[[end_body]] table for each pole that has one.",
    "Spin": "The spin of the reference state of a membrane without pressure (a disc).",
    "Beam": "A straight beam along x (kind = \"beam\").",
    "Hub": "The rigid hub of a spacecraft (kind = \"spacecraft\") or of a flat membrane "
    "clamped to it (annulus, square sail, heliogyro strips).",
    "Boom": "A straight 3-D beam clamped to the hub; repeat [[boom]] for each boom.",
    "TipMass": "A point mass at a corner of a square sail, spread over a small patch of the "
    "membrane there; repeat [[tip_mass]] for each corner that has one.",
    "Modes": "How many elastic modes the model case computes.",
    "RunCase": "A run case: a model with the reduced model, initial state and time integration "
    "of one run.",
    "RunReduced": "The reduced model of the run (quadratic modes by default).",
    "RunInitial": "The initial state of a free-body run.",
    "RunIntegration": "The time integration of a free-body run.",
    "RunSpinup": "A hub-driven spin-up of a clamped beam, or a spin change of a body on a hub "
    "(replaces [initial] and [integration]).",
}

FIELD_DOCS: dict[str, dict[str, str]] = {
    "Case": {
        "name": "the case's name (letters, digits, '.', '_', '-'): names output and cache files",
        "description": "one line saying what the case is for (shown by `quadmodes cases`)",
        "kind": "the structure: a membrane (inflated or spinning), a beam, or a spacecraft "
        "(hub and booms)",
        "geometry": "the membrane's shape (membrane cases)",
        "mesh": "the triangulation (membrane cases)",
        "material": "the membrane's material (membrane cases)",
        "pressure": "the inflation (membrane cases, except the open flat ones)",
        "end_body": "rigid bodies at the poles (membrane cases; at most one per pole)",
        "spin": "the reference spin of an open flat membrane (disc, annulus, square, strip, flat "
        "mesh file; membrane cases without pressure only)",
        "beam": "the beam (kind = \"beam\")",
        "hub": "the rigid hub (kind = \"spacecraft\"; or the hub an annulus, square sail or "
        "strips are clamped to)",
        "boom": "the booms on the hub (kind = \"spacecraft\")",
        "tip_mass": "point masses at the corners of a square sail",
        "modes": "the modes computed",
    },
    "Geometry": {
        "shape": "sphere-cone: two spherical caps joined by a tangent cone; sphere; capsule: a "
        "cylinder with hemispherical ends; flat-cylinder: a cylinder closed by flat discs; "
        "disc: an open flat membrane (no pressure); annulus, square, strip: open flat membranes "
        "clamped to a rigid [hub] (a spinning annulus, an IKAROS-like square sail, heliogyro "
        "blades); file: a surface mesh file",
        "length": "overall pole-to-pole length L of the body along its axis (sphere-cone, "
        "capsule, flat-cylinder)",
        "front_cap_diameter": "diameter of the front (z = 0) spherical cap of a sphere-cone",
        "rear_cap_diameter": "diameter of the rear (z = L) spherical cap of a sphere-cone",
        "diameter": "diameter of a sphere, of a capsule's or flat-cylinder's cylinder, or the "
        "outer diameter of a disc or annulus",
        "inner_diameter": "diameter of the central hole whose edge is clamped to the rigid hub "
        "(annulus, square sail; for strips the blade roots sit at half of it from the axis; for a "
        "flat mesh file the boundary nodes within it are clamped)",
        "side_length": "side of the square sail (centred on the spin axis z)",
        "width": "width of each heliogyro strip (its length is `length`, radially from the hub)",
        "blades": "number of heliogyro strips, evenly spaced about the hub",
        "file": "a surface mesh in any format meshio reads (.vtu, .stl, .obj, .msh …): closed "
        "for a pressurised membrane, flat and open with [spin]; a relative path is taken from "
        "the case file's folder",
        "file_unit": "the length unit of the mesh file's coordinates (default metres)",
    },
    "Mesh": {
        "edge_length": "target triangle edge length h; at most half the largest radius (about "
        "a tenth is a good start)",
        "elements_per_radius": "grading: at least this many edges per hoop radius of curvature "
        "(refines small caps)",
        "elements_per_attach_radius": "grading: edges of attach_radius / this value at the rim "
        "of each end body's rigid patch, growing away from it",
        "mass_matrix": "consistent or lumped (row-sum) membrane mass matrix",
    },
    "Material": {
        "density": "mass density ρ of the membrane material",
        "youngs_modulus": "Young's modulus E",
        "poisson_ratio": "Poisson's ratio ν",
        "thickness": "membrane thickness t",
        "damping_ratio": "modal damping ratio ζ of every elastic mode (2 % is the seed's)",
        "wrinkling": "tension-field: the membrane wrinkles where it would be compressed (flat "
        "ends, corners); none: it carries compression (St Venant–Kirchhoff), refused when over "
        "5 % of it is compressed after inflation",
    },
    "Pressure": {
        "value": "gauge inflation pressure p",
        "gas_law_exponent": "polytropic exponent κ of the gas (p V^κ constant during vibration); "
        "0 keeps p constant, 1 isothermal, 1.4 adiabatic air",
        "steps": "load steps of the inflation: the first pressure increment is value / steps "
        "(default 1: the whole pressure at once, cut automatically where that fails); raise it "
        "when the inflation fails",
    },
    "EndBody": {
        "name": "the body's name (used in mode labels, e.g. \"rocking (tip)\")",
        "pole": "the pole that carries it: front (z = 0) or rear (z = L)",
        "mass": "the body's mass m",
        "inertia_axial": "moment of inertia about the body axis, through the body's own centre "
        "(with inertia_transverse; or give radius and height)",
        "inertia_transverse": "moment of inertia about a transverse axis through the body's own "
        "centre (with inertia_axial)",
        "radius": "radius of the uniform solid cylinder whose inertia the body has (with height; "
        "instead of inertia_axial and inertia_transverse)",
        "height": "height of that uniform solid cylinder, along the body axis",
        "attach_radius": "membrane nodes of the cap within this distance of the axis are tied "
        "rigidly to the body (the bonded patch); smaller than the cap or end radius",
        "offset": "the body's centre of mass lies this far outside the pole, on the axis",
        "arm": "half-size of the point-mass cluster that carries the inertia (default: 1.25 × "
        "the smallest that works)",
        "attachment": "rim: the rigid patch meets the bare membrane at a sharp rim; flange: a "
        "bonded doubler between attach_radius and flange_radius",
        "flange_radius": "outer radius of the bonded flange (attachment = \"flange\")",
        "flange_thickness_factor": "the flange is this many times as thick as the membrane "
        "(attachment = \"flange\")",
    },
    "Spin": {"rate": "spin rate Ω of the reference state about the disc's normal"},
    "Beam": {
        "length": "beam length",
        "elements": "number of beam elements",
        "area": "cross-section area A",
        "second_moment": "second moment of area I (both bending planes)",
        "youngs_modulus": "Young's modulus E",
        "density": "mass density ρ",
        "support": "clamped at x = 0 (on a hub) or free",
        "damping_ratio": "modal damping ratio ζ of every elastic mode",
        "element": "beam3d: bending in both planes, extension, torsion and rotary inertia; "
        "cable: the ANCF cable without torsion (Kane's benchmark)",
        "shear_modulus": "shear modulus G of the 3-D beam (default E / 2.6)",
        "torsion_constant": "torsion constant J of the 3-D beam (default 2 I, a circular section)",
    },
    "Hub": {
        "mass": "the hub's mass",
        "inertia_x": "principal moment of inertia about x through the hub's centre",
        "inertia_y": "principal moment of inertia about y through the hub's centre",
        "inertia_z": "principal moment of inertia about z through the hub's centre",
        "damping_ratio": "modal damping ratio ζ of every elastic mode of the whole structure",
        "rigidity": "stiffness of the hub's rigid triad relative to the stiffness of what is "
        "attached to it (boom roots; a clamped membrane's rim): the hub deforms 1/rigidity as "
        "much",
    },
    "TipMass": {
        "name": "a label for the tip mass (e.g. its corner)",
        "corner": "the corner of the square sail it sits at (+x+y, -x+y, -x-y or +x-y)",
        "mass": "the tip mass",
        "patch": "radius of the corner patch of membrane it is bonded to and spread over (by area)",
    },
    "Boom": {
        "name": "the boom's name (unique)",
        "azimuth": "the boom's direction in the hub's x-y plane, from x",
        "elevation": "the boom's direction above the hub's x-y plane",
        "root_radius": "distance of the boom's root from the hub axis, along its direction",
        "root_height": "height of the boom's root along z",
        "length": "boom length",
        "elements": "number of beam elements",
        "area": "cross-section area A",
        "second_moment": "second moment of area I (both bending planes)",
        "youngs_modulus": "Young's modulus E",
        "density": "mass density ρ",
        "shear_modulus": "shear modulus G (default E / 2.6)",
        "torsion_constant": "torsion constant J (default 2 I, a circular section)",
    },
    "Modes": {"count": "number of elastic modes u^m the model case computes (the lowest)"},
    "RunCase": {
        "name": "the run's name (letters, digits, '.', '_', '-')",
        "description": "one line saying what the run is for",
        "kind": "always \"run\" for a run case",
        "model": "the model: a built-in case name, a case file (relative to this file), or the "
        "model itself as a [model] table with [model.geometry] … below it",
        "reduced": "the reduced model",
        "initial": "the initial state (free-body runs)",
        "integration": "the time integration (free-body runs)",
        "spinup": "a hub-driven spin-up of a clamped beam or a spin change of a body on a hub "
        "(instead of [initial], [integration])",
    },
    "RunReduced": {
        "modes": "number N of elastic modes u^m kept (the lowest), or \"auto\": every mode up "
        "to mode_margin × the spin frequency, pairs whole, at least the first bending pair",
        "formulation": "Q: quadratic modes (the seed's method); P: the seed's printed equations; "
        "L: linear modes; rigid: no elastic modes; Q4: Q with the quartic manifold potential; "
        "QM: the quadratic manifold's exact kinetic energy with Q4's potential",
        "mode_margin": "with modes = \"auto\": keep modes up to this multiple of the spin "
        "frequency (default 2.5 about rest, 3.2 about the spinning state)",
        "reference": "the state the reduced model is expanded about: rest (the inflated state, "
        "as the seed) or spinning (the centrifugal equilibrium at the initial spin)",
        "path_model": "fixed: one model for the whole path; spin-family: models about spins "
        "path_switch apart, the one nearest the path's spin integrating (reference spinning)",
        "path_switch": "with path_model = \"spin-family\": the spacing of the members' spins "
        "(a fraction of the spin; default 0.0075: departures up to about 0.41 %)",
        "path_tolerance": "with path_model = \"spin-family\": members chosen adaptively, each "
        "used where its energy-sink coning rate is within this fraction of a member's about the "
        "path's spin (measured between neighbours; instead of path_switch)",
    },
    "RunInitial": {
        "spin_rate": "initial spin rate Ω about the spin axis",
        "cone_angle": "initial cone angle θ between the angular momentum and the spin axis",
        "bending_amplitude": "initial deformation in the first bending mode: its largest nodal "
        "displacement (0: undeformed); keep it inside the taut range (`quadmodes modes`)",
        "spin_axis": "body-frame spin axis: minor (default), intermediate, major, x, y, z or "
        "three numbers; it must be a principal axis",
    },
    "RunIntegration": {
        "method": "midpoint (energy-conserving implicit midpoint), backward-euler, or adaptive",
        "dt": "time step Δt (for adaptive: the sampling step); resolve the spin and the highest "
        "kept mode (about 20 steps a period)",
        "duration": "length of the run",
        "save_every": "keep every n-th step in results.nc",
        "rtol": "relative tolerance of the adaptive method",
        "until": "an event that ends the run before its duration, located to the step: "
        '"cone A deg" (cone angle θ reaches A), "spin W Hz" (spin rate reaches W), "time T s", '
        'or "flat spin" (optionally "flat spin A deg": within A of the major axis)',
        "step_tolerance": "a controlled step (midpoint only): between chunks the step is chosen so "
        "that the step-doubling estimate of the relative error of the dissipated power (of the "
        "body-frame state for an undamped body) stays below this, and E + E_d within 1e-6 of "
        "the energy; dt is then the first step (docs/long-paths.md)",
    },
    "RunSpinup": {
        "omega_0": "spin before the change (0: a clamped beam from rest); > 0: a spin change of a "
        "body on a [hub] by a torque on the hub, its model about this spinning state",
        "omega_s": "final hub spin rate Ω_s",
        "ramp_time": "time of the smooth ramp from Ω_0 to Ω_s",
        "duration": "length of the run (Ω_s held after the ramp)",
        "rtol": "relative tolerance of the DOP853 integrator",
        "samples": "number of output samples",
    },
}
