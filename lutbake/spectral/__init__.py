"""The spectral integral: RGB = ∫ w_c(λ) R(λ) dλ of the Airy reflectance against the colour weights
(docs/spectral.md).

Stages, a module each: ``rules`` (SpectralRule, RuleLadder: where R(λ) is sampled and with what weights;
``panel_rule``, ``wavenumber_rule``, ``rule_ladder``), ``fourier`` (WeightTransform, ``weight_transform``:
the transform of the colour weights; ``series_coefficients``, ``series_plan``, ``series_colour``: the exact
Fourier series of a texel and the rule that picks it), ``poles`` (CauchyTable, ChebyshevRule,
``closed_form``: that series in closed form by its poles, where it converges slowly) and ``reference``
(``reference_colour``, ``reference_rgb``: the converged ground truth every fast path is measured against).
"""
