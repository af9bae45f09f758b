"""The direct quadrature on the device: kernels/airy.cl's bake_texels_direct sums each texel's reflectance
at its spectral rule's nodes (lutbake/spectral/rules.py, the level the host picks per texel). It bakes
every texel under ``integrator='direct'``, and what the series and the closed form leave otherwise
(evanescent films, films whose poles are too many: lutbake/integrate/series.py)."""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from lutbake.integrate.program import DeviceProgram, signed_cos_theta2, split_hi_lo

if TYPE_CHECKING:
    import pyopencl

    from lutbake.grid.spec import BakeSpec

__all__ = ["DirectOnDevice"]


class DirectOnDevice:
    """The direct quadrature's inputs for one spec on one device: the grid's nodes and every rule level's
    nodes and weights."""

    def __init__(self, program: DeviceProgram, spec: BakeSpec):
        self.program, self.spec = program, spec
        rules = [spec.ladder.rule(k) for k in range(len(spec.ladder.counts))]
        nu = np.concatenate([1.0 / r.wavelength_nm for r in rules])
        weights = np.concatenate([r.weights.ravel() for r in rules])
        cos_t, opd, kappa3 = (spec.node_values(n) for n in ("cos_theta", "opd_nm", "kappa3"))
        cos2 = signed_cos_theta2(spec.eta1, spec.eta2, cos_t)
        # The phase inputs go in as float-float pairs (exact in float64 mode: lo = 0). D and κ3 per
        # (node, cos θ1 node), row-major: the corner zoom moves them with the incidence.
        arrays = [
            cos_t,
            *split_hi_lo(cos2, program.dtype),
            *split_hi_lo(opd.ravel(), program.dtype),
            spec.eta3_columns(),
            kappa3.ravel(),
            *split_hi_lo(nu, program.dtype),
            weights,
        ]
        self._inputs = [program.input(a) for a in arrays]

    def enqueue(self, y0: int, texels: np.ndarray, levels: np.ndarray, out: pyopencl.Buffer) -> list[pyopencl.Buffer]:
        """Enqueue the quadrature at ``texels`` (indices in the band starting at row y0), each at its rule
        level, into ``out``; the buffers it reads (to keep until it is done)."""
        program, spec, real = self.program, self.spec, self.program.dtype
        n_cos, n_opd, _, _ = spec.shape
        texel_buf, level_buf = (program.input(a, np.int32) for a in (texels, levels))
        program.run(
            program.kernels.bake_texels_direct,
            len(texels),
            *self._inputs,
            texel_buf,
            level_buf,
            real(spec.eta1),
            real(spec.eta2),
            np.int32(n_cos),
            np.int32(n_opd),
            np.int32(spec.image_size[0]),
            np.int32(y0),
            np.int32(spec.ladder.counts[0]),
            out,
        )
        return [texel_buf, level_buf]
