"""Names of the CIE observers and working spaces (and colour-science's names for them), of the
LUT interpolation rules (lutbake/interpolation.py) and of the η3 spacings that follow the incidence
(lutbake/plan.py).

Kept apart from colorimetry.py, with no imports, so the command line can list
the choices at start-up without loading numpy or colour-science.
"""

OBSERVERS = {
    "cie1931": "CIE 1931 2 Degree Standard Observer",
    "cie1964": "CIE 1964 10 Degree Standard Observer",
}

SPACES = {
    "rec709": "Linear Rec.709 (sRGB)",
    "acescg": "ACEScg",
    "rec2020": "Linear Rec.2020",
    "p3": "Linear P3-D65",
}

INTERPOLATIONS = ("cubic", "linear")

ADMITTANCE_SPACINGS = ("admittance", "sqrt-admittance")   # η3 only: nodes per cos θ1 node
