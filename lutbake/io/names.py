"""Names of the CIE observers and working spaces (and colour-science's names for them), of the
LUT interpolation rules (lutbake/grid/interpolation.py) and of the η3 spacings that follow the incidence
(lutbake/grid/axis.py); and how a file, scene or material name may appear in shader source (a // comment,
a constant's identifier, an OSL string): the file name itself stays intact everywhere else.

Kept apart from lutbake/physics/colorimetry.py, with no imports, so the command line can list
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

ADMITTANCE_SPACINGS = ("admittance", "sqrt-admittance")  # η3 only: nodes per cos θ1 node


def shader_identifier(name: str) -> str:
    """A GLSL/HLSL constant name for a LUT, scene or material ``name``: LUTBAKE_ + its ASCII letters and
    digits in upper case, any other ASCII character as _, a non-ASCII one as _U<hex code point>_ (so
    'stål' and 'stal' stay apart), runs of _ folded into one (glslang reserves identifiers with __,
    WebGL refuses them). Identifiers may hold ASCII letters, digits and _ only (GLSL ES 3.00 §3.7).

    >>> shader_identifier("lutbake-eta2-1.33"), shader_identifier("stål_steel"), shader_identifier("a--b")
    ('LUTBAKE_ETA2_1_33', 'LUTBAKE_ST_UE5_L_STEEL', 'LUTBAKE_A_B')
    """
    chars = (c.upper() if c.isascii() and c.isalnum() else "_" if c.isascii() else f"_U{ord(c):X}_" for c in name)
    ident = "_".join(part for part in "".join(chars).split("_") if part)
    return ident if ident.startswith("LUTBAKE_") else f"LUTBAKE_{ident}"


def shader_comment(text: str) -> str:
    """``text`` as it may stand in a // comment of GLSL or HLSL: printable ASCII kept, anything else (a
    newline that would end the comment and put the rest in the source, a backslash that would continue it
    onto the next line, non-ASCII that some compilers reject) written as a Python escape (\\n, \\xfc, \\u00e5;
    a backslash as \\x5c, never before the end of the line).

    >>> shader_comment("nl\\n#error injected\\n.exr"), shader_comment("ü.exr")
    ('nl\\\\n#error injected\\\\n.exr', '\\\\xfc.exr')
    """
    return "".join(c if " " <= c <= "~" and c != "\\" else "\\x5c" if c == "\\" else ascii(c)[1:-1] for c in text)


def terminal_text(text: str) -> str:
    """``text`` as one line that a terminal shows as it is written: every character Python does not call
    printable (a newline that would start a second line, an escape sequence that would recolour the
    terminal or move its cursor, C1 controls, line separators) as its Python escape; the rest, non-ASCII
    included, unchanged.

    >>> terminal_text("key\\nlutbake: error: forged\\x1b[2J"), terminal_text("stål")
    ('key\\\\nlutbake: error: forged\\\\x1b[2J', 'stål')
    """
    return "".join(c if c.isprintable() else ascii(c)[1:-1] for c in text)


def shader_string(text: str) -> str:
    """``text`` as it may stand between the double quotes of an OSL string (an OSL script's table path):
    unchanged; ValueError when it holds a double quote or a control character (a newline would end the
    string and put the rest in the source), which no escape carries through every OSL compiler alike.

    >>> shader_string("/tables/rt.exr")
    '/tables/rt.exr'
    >>> shader_string("/tables/rt\\n#error.exr")
    Traceback (most recent call last):
    ...
    ValueError: '/tables/rt\\n#error.exr' holds a double quote or a control character, which an OSL string cannot hold
    """
    if any(c == '"' or c < " " or c == "\x7f" for c in text):
        raise ValueError(f"{text!r} holds a double quote or a control character, which an OSL string cannot hold")
    return text
