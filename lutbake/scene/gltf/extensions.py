"""What other glTF material extensions change about the film's stack (docs/gltf.md, "Other extensions").

``KHR_materials_specular`` changes the dielectric base's F0, and so the base under the film: its
KHR_materials_iridescence section gives the film term's base F0 as
``specular * min(((ior - 1)/(ior + 1))^2 * specularColor, 1)`` per channel, which lutbake reads as a real
index per channel (the inverse of the normal-incidence Fresnel equation, as the extension's own
``Fresnel0ToIor`` does). Its textures vary that F0 per texel, which a baked slice cannot follow: lutbake
bakes the factors and names the textures in one warning per asset. Extensions that put a layer over the film
or change what the base does beyond its reflectance (clearcoat, sheen, transmission, volume, ...) are named
in one warning per asset: KHR_materials_iridescence defines the film term without them, and lutbake bakes
that term.
"""

from __future__ import annotations

__all__ = ["SPECULAR", "SPECULAR_TEXTURES", "OTHER_LAYERS", "EXCLUDED", "dielectric_f0", "asset_notes"]

SPECULAR = "KHR_materials_specular"
SPECULAR_TEXTURES = ("specularTexture", "specularColorTexture")
# Extensions lutbake does not read that change what lies over the film or what the base does.
OTHER_LAYERS = {
    "KHR_materials_clearcoat": "a coat over the film (KHR_materials_iridescence ignores its interface)",
    "KHR_materials_sheen": "a sheen layer over the film",
    "KHR_materials_transmission": "a transmitting base (its light through the base is the engine's)",
    "KHR_materials_diffuse_transmission": "a diffusely transmitting base",
    "KHR_materials_volume": "a volume behind the base",
    "KHR_materials_dispersion": "a base index that varies with wavelength (lutbake bakes the constant ior)",
    "KHR_materials_anisotropy": "an anisotropic specular lobe",
}
# KHR_materials_iridescence, Exclusions: "This extension must not be used on a material that also uses" these.
EXCLUDED = ("KHR_materials_pbrSpecularGlossiness", "KHR_materials_unlit")

_WHY = {  # why an extension, or what lutbake cannot follow, is named
    "KHR_materials_pbrSpecularGlossiness": "KHR_materials_iridescence must not be used with it",
    "KHR_materials_unlit": "KHR_materials_iridescence must not be used with it",
    "specular textures": "KHR_materials_specular's textures vary the base F0 per texel: baked at its factors",
}


def dielectric_f0(ior: float, specular: float, colour: list[float]) -> list[float]:
    """The film term's dielectric base F0 per channel (KHR_materials_iridescence with KHR_materials_specular:
    ``base_f0 = min(((1 - ior)/(1 + ior))^2 * specularColor, 1)``, then ``specular_weight * base_f0``).
    ``ior`` 0 (KHR_materials_ior's specular-glossiness mode) gives F0 1 before the colour, as its +∞ index."""
    f0_ior = ((1.0 - ior) / (1.0 + ior)) ** 2
    return [specular * min(f0_ior * c, 1.0) for c in colour]


def asset_notes(notes: dict[str, list[str]]) -> list[str]:
    """One warning line per asset from {extension: [material labels]} (empty: none)."""
    if not notes:
        return []
    named = "; ".join(
        f"{ext} on {', '.join(labels)}: {_WHY.get(ext) or OTHER_LAYERS[ext]}" for ext, labels in notes.items()
    )
    return [
        f"iridescent materials use extensions that change what the film sits on or lies under: {named}. "
        "lutbake bakes the film term as KHR_materials_iridescence defines it over the base it reads; "
        "what these extensions add is left to the engine"
    ]
