"""The kernels at given points rather than over a grid: the reflectance at stacks and wavelengths
(kernels/airy.cl's reflectance_points: the self-check, ``OpenCLBackend.evaluate``) and one film stack's
colour at many (cos θ1, d) with dispersive indices (stack_terms, then stack_rgb: a scene's slices,
lutbake/scene/slices.py)."""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np
import numpy.typing as npt

from lutbake.integrate.program import DeviceProgram, signed_cos_theta2, split_hi_lo
from lutbake.physics.points import FilmPoints

if TYPE_CHECKING:
    from lutbake.spectral.rules import SpectralRule

__all__ = ["kernel_reflectance", "kernel_stack_colour"]

# Nodes per work-item of stack_rgb: its few stiff points on the finest rules still spread over every core.
STACK_BLOCK = 256
STACK_TERMS = 18  # reals per (cos θ1, node) in stack_terms' output (STACK_TERMS in airy.cl)


def kernel_reflectance(program: DeviceProgram, stack: FilmPoints, wavelength_nm: npt.ArrayLike) -> np.ndarray:
    """The kernel's unpolarized R of the stacks at ``wavelength_nm`` (broadcast as
    optics.film_reflectance; one ambient η1, named materials taken at each wavelength): its physics,
    node by node."""
    real = program.dtype
    eta1 = float(np.ravel(stack.eta1)[0])
    stack.require("kernel", eta1=eta1)  # one ambient index per launch
    eta2, eta3, kappa3 = (_distinct(v) for v in stack.indices(wavelength_nm))
    lam = np.asarray(wavelength_nm, np.float64)
    cos1 = np.asarray(stack.cos_theta, np.float64)
    shape = np.broadcast_shapes(
        cos1.shape, eta2.shape, eta3.shape, kappa3.shape, np.shape(stack.thickness_nm), lam.shape
    )
    # each input computed where it varies (per stack, per wavelength), then spread over the rest as it is uploaded
    arrays = [
        cos1.astype(real),
        *split_hi_lo(signed_cos_theta2(eta1, eta2, cos1), real),
        *split_hi_lo(2.0 * eta2 * stack.thickness_nm, real),
        *(np.asarray(v, real) for v in (eta2, eta3, kappa3)),
        *split_hi_lo(1.0 / lam, real),
    ]
    size = int(np.prod(shape))
    inputs = [program.input(np.broadcast_to(a, shape or (1,)).ravel()) for a in arrays]  # split_hi_lo: 0-d as (1,)
    out = np.empty(size, real)
    out_buf = program.scratch(out.nbytes, "w")
    program.run(program.kernels.reflectance_points, size, *inputs, real(eta1), out_buf)
    program.read(out, out_buf)
    return out.astype(np.float64).reshape(shape)


def _distinct(values: np.ndarray) -> np.ndarray:
    """``values`` (a broadcast view) with each axis it is repeated along (stride 0) kept once."""
    return values[tuple(slice(None) if stride else slice(0, 1) for stride in values.strides)]


def kernel_stack_colour(
    program: DeviceProgram,
    eta1: float,
    cos_theta: npt.ArrayLike,
    thickness_nm: npt.ArrayLike,
    node_indices: tuple[npt.ArrayLike, npt.ArrayLike, npt.ArrayLike],
    rule: SpectralRule,
) -> np.ndarray:
    """RGB (P, 3) of one film stack at points (cos θ1, d), by ``rule`` with the film's and base's
    indices per node (``node_indices`` = (η2, η3, κ3), each (N,): dispersive materials): the
    kernel's reflectance summed on the device, its Fresnel side once per distinct cos θ1 × node."""
    real = program.dtype
    eta2, eta3, kappa3 = (np.broadcast_to(np.asarray(v, np.float64), (rule.count,)) for v in node_indices)
    thickness_nm = np.asarray(thickness_nm, np.float64)
    cos_values, cos_index = np.unique(np.asarray(cos_theta, np.float64), return_inverse=True)
    cos2 = signed_cos_theta2(eta1, eta2[None, :], cos_values[:, None]).ravel()
    cos2_hi, cos2_lo = (program.input(a) for a in split_hi_lo(cos2, real))
    cos1, eta2_buf = program.input(cos_values), program.input(eta2)
    terms = program.scratch(cos_values.size * rule.count * STACK_TERMS * np.dtype(real).itemsize)
    program.run(
        program.kernels.stack_terms,
        cos_values.size * rule.count,
        cos1,
        cos2_hi,
        eta2_buf,
        program.input(eta3),
        program.input(kappa3),
        real(eta1),
        real(thickness_nm.max()),
        np.int32(rule.count),
        terms,
    )
    n_blocks = -(-rule.count // STACK_BLOCK)
    out = np.empty((n_blocks, cos_index.size, 3), real)
    out_buf = program.scratch(out.nbytes, "w")
    program.run(
        program.kernels.stack_rgb,
        out.size // 3,
        cos1,
        cos2_hi,
        cos2_lo,
        terms,
        program.input(cos_index, np.int32),
        *(program.input(a) for a in split_hi_lo(thickness_nm, real)),
        eta2_buf,
        *(program.input(a) for a in split_hi_lo(1.0 / rule.wavelength_nm, real)),
        program.input(rule.weights),
        np.int32(rule.count),
        np.int32(STACK_BLOCK),
        np.int32(cos_index.size),
        out_buf,
    )
    program.read(out, out_buf)
    return out.astype(np.float64).sum(axis=0)
