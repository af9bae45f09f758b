"""The physics of one film stack: colorimetry, materials, the stack itself, its Airy reflectance (docs/optics.md).

Stages, a module each, lowest first: ``colorimetry`` (observers, working spaces, the illuminant-weighted
sensitivities and ΔE00: ``Colorimetry``, ``colorimetry``, ``delta_e00``, ``OBSERVERS``, ``SPACES``;
docs/spectral.md), ``materials`` (named dispersive indices from refractiveindex.info: ``material``,
``catalogue``, ``DispersiveMaterial``, ``ConstantMaterial``, ``ALIASES``), ``points`` (FilmPoints: P film
stacks, checked where values enter against the input domain of docs/stability.md; ``check_value``,
``inside_domain``, ``read_csv_columns``, ``dielectric_film``, ``opd_from_thickness``, ``thickness_from_opd``),
``optics`` (Fresnel amplitudes and the closed-form Airy sum: ``film_reflectance``, ``film_transmittance``,
``film_amplitudes``, ``normal_admittance``, ``fresnel_s``, ``fresnel_p``, ``round_trip_amplitude``),
``fringes`` (the same R of a constant, lossless, propagating film as a function of its phase alone, the ground
truth's per-node form: ``fringe_points``, ``fringe_terms``, ``fringe_reflectance``, ``fringe_polarized``) and
``metals`` (glTF base colours as conductors η + iκ: ``conductor``, ``conductor_reflectance``,
``gltf_metal_reflectance``, ``reflectance_error``, ``MAPPINGS``, ``F0_MAX``; docs/gltf.md).
"""
