"""Blender from lutbake: write a scene bake's node-group library, and check it renders what lutbake samples.

Blender runs as a separate program: a Blender executable (run with ``--background --python``) or a
Python interpreter with the ``bpy`` module (PyPI's bpy 5.0.1 needs Python 3.11 and numpy < 2, which
lutbake's own dependencies exclude, so it lives in an environment of its own). Inside it run two
scripts of this package that import nothing of lutbake: ``lutbake/blender/nodes.py`` (the node groups and
materials, built from the reads of lutbake/blender/programs.py, which it loads by path; and the OSL
materials: the exact runtime mode and the runtime table, scripts filled in from
shaders/exact.osl.in and shaders/runtime.osl.in) and
``lutbake/blender/probe.py`` (renders probe planes). This module finds Blender, checks the inputs before it
starts, commits the .blend atomically, and compares renders with ``lutbake sample``, with the exact
mode's float64 evaluation and with the runtime table's float32 model (docs/blender.md).
"""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import tempfile
import time
from collections.abc import Callable
from dataclasses import dataclass
from functools import partial
from os import PathLike
from pathlib import Path
from typing import Any

import numpy as np

from lutbake.blender.nodes import OSL_MATERIALS, osl_warning
from lutbake.blender.programs import BLENDER_SPACES, LutRead, SceneReads, SliceRead, scene_reads
from lutbake.errors import ParameterError
from lutbake.io.documents import load_json, read_text
from lutbake.io.manifest import read_scene_manifest
from lutbake.lut.sample import Atlas, Lut
from lutbake.modes.exact import METALS, RGB_WAVELENGTHS_NM, ExactTable, exact_colour, read_exact_table
from lutbake.modes.runtime.files import RuntimeTable, read_runtime_table
from lutbake.modes.runtime.model import runtime_colour
from lutbake.physics.colorimetry import delta_e00
from lutbake.physics.materials import material
from lutbake.physics.points import FilmPoints
from lutbake.quality.runtime_accuracy import truth
from lutbake.tables.headers import MAX_ATTRIBUTE_BYTES
from lutbake.tables.includes import osl_source
from lutbake.tables.lutfile import atomic_path

__all__ = [
    "BLENDER_ENV",
    "RENDER_TOLERANCE",
    "BlenderError",
    "find_blender",
    "build_library",
    "write_library",
    "render_probes",
    "verify_library",
    "verify_osl",
    "osl_script",
    "osl_probe_points",
    "osl_job_probes",
    "probe_points",
    "lutbake_probes",
    "blender_thin_film_probes",
]

BLENDER_ENV = "LUTBAKE_BLENDER"
RENDER_TOLERANCE = 1e-3  # |ΔRGB| a render may differ from `lutbake sample` (issue 25's bound)
_SCRIPTS = Path(__file__).parent
_INSTALL = (
    "a Blender executable on PATH, or --blender PATH (a Blender executable, or a Python 3.11 with the "
    "bpy module: python3.11 -m venv .venv-blender && .venv-blender/bin/pip install bpy==5.0.1), or "
    f"${BLENDER_ENV}"
)


class BlenderError(RuntimeError):
    """Blender ran and failed (not bad input): the last line of its error output."""


def find_blender(explicit: str | None = None) -> str:
    """The Blender to run: ``explicit``, else ``blender`` on PATH; ParameterError (one line, what to install)
    when there is none. (The command line passes $LUTBAKE_BLENDER as ``explicit`` when --blender is not
    given; the library reads no environment.)"""
    chosen = explicit or shutil.which("blender")
    if not chosen:
        raise ParameterError("no Blender found: need {what}", what=_INSTALL)
    path = shutil.which(chosen)
    if path is None:
        raise ParameterError(
            "{blender} {chosen} is not an executable file: need {what}", chosen=repr(chosen), what=_INSTALL
        )
    return path


def _command(blender: str, script: str, args: list[str]) -> list[str]:
    """A Python with bpy runs the script itself; a Blender executable runs it headless on an empty file."""
    if Path(blender).name.startswith("python"):
        return [blender, str(_SCRIPTS / script), *args]
    return [
        blender,
        "--background",
        "--factory-startup",
        "--python-exit-code",
        "1",
        "--python",
        str(_SCRIPTS / script),
        "--",
        *args,
    ]


def _run(blender: str, script: str, args: list[str], timeout_s: float = 600.0) -> float:
    """Run a script in Blender; its wall seconds. BlenderError with Blender's last error line on failure."""
    start = time.perf_counter()
    try:
        done = subprocess.run(_command(blender, script, args), capture_output=True, text=True, timeout=timeout_s)
    except subprocess.TimeoutExpired:
        raise BlenderError(f"{script} did not finish in {timeout_s:g} s") from None
    errors = [line for line in done.stderr.splitlines() if line.strip()]
    if done.returncode == 2 and errors:  # the script's own one-line input error
        raise ParameterError("{detail}", detail=errors[-1].removeprefix("lutbake: error: "))
    if done.returncode != 0:
        lines = [line for line in (done.stderr + done.stdout).splitlines() if line.strip()]
        raise BlenderError(
            f"Blender ({blender}) failed running {script} (exit {done.returncode}): "
            f"{lines[-1] if lines else 'no output'}"
        )
    return time.perf_counter() - start


def write_library(
    manifest: str | PathLike[str] | None,
    out: str | PathLike[str],
    blender: str | None = None,
    pack: bool = True,
    exact: str | PathLike[str] | None = None,
    runtime_table: str | PathLike[str] | None = None,
) -> dict[str, Any]:
    """Write ``out`` (.blend): one node group and one material per material of the scene bake whose
    manifest is ``manifest`` (lutbake/blender/nodes.py), with ``exact`` (an `exact-table` EXR) the exact mode's
    OSL material and with ``runtime_table`` (a `runtime-table` EXR) the runtime table's; committed
    atomically (nothing is written on failure).

    Parameters
    ----------
    manifest : str or os.PathLike or None
        SCENE.json of a scene bake (its atlas and 4D LUTs beside it); None with an OSL table only.
    out : str or os.PathLike
        The .blend to write.
    blender : str, optional
        A Blender executable or a Python with bpy (default: ``find_blender()``).
    pack : bool
        Pack the EXRs into the .blend (default) rather than reference them by relative path.
    exact : str or os.PathLike, optional
        An exact-mode table (`lutbake exact-table`): the OSL script reads it at its path relative to the
        .blend (``//``, which Cycles resolves against the .blend's folder), and the .blend holds it as an
        image too (packed unless ``pack`` is False), which Pack Resources and Report Missing Files see.
    runtime_table : str or os.PathLike, optional
        A runtime table (`lutbake runtime-table`), likewise.

    Returns
    -------
    dict
        ``library`` (the path), ``groups`` (material → node group name), ``working_space`` (Blender's name
        of the bake's space: the library file's, and the one a file that appends the groups must use),
        ``osl_materials`` (kind → OSL material name), ``warnings`` (one line per OSL material: where it
        does not run, and what it shows there), ``blender``, ``seconds``.
    """
    tables = {kind: table for kind, table in (("exact", exact), ("runtime", runtime_table)) if table is not None}
    if manifest is None and not tables:
        raise ParameterError("nothing to write: give a scene manifest, {exact}, {runtime_table}, or several")
    scene = read_scene(manifest) if manifest is not None else None
    out = Path(out)
    scripts = {kind: osl_script(kind, table, out.absolute().parent) for kind, table in tables.items()}
    if out.suffix != ".blend":
        raise ParameterError("{out_path} {out} must end in .blend", out=repr(str(out)))
    if out.is_dir():
        raise ParameterError("{out_path} {out} is a folder, expected a file or nothing", out=repr(str(out)))
    exe = find_blender(blender)
    out.parent.mkdir(parents=True, exist_ok=True)
    args = [str(Path(manifest).absolute())] if manifest is not None else []
    with atomic_path(out) as tmp, tempfile.TemporaryDirectory(prefix="lutbake-blender-") as folder:
        blend = tmp.with_name(tmp.name + ".blend")  # Blender saves only to a name ending in .blend
        for kind, text in scripts.items():
            (Path(folder) / f"lutbake_{kind}.osl").write_text(text)
            args += ["--osl", str(Path(folder) / f"lutbake_{kind}.osl"), str(Path(tables[kind]).absolute())]
        try:
            seconds = _run(exe, "nodes.py", [*args, "--out", str(blend.absolute()), *([] if pack else ["--link"])])
            os.replace(blend, tmp)
        finally:
            blend.unlink(missing_ok=True)
    groups = {r.material: scene.group_name(r.material) for r in scene.reads} if scene else {}
    return {
        "library": str(out),
        "groups": groups,
        "working_space": BLENDER_SPACES[scene.space] if scene else None,
        "osl_materials": {kind: _osl_material(kind) for kind in scripts},
        "warnings": [osl_warning(_osl_material(kind)) for kind in scripts],
        "blender": exe,
        "seconds": seconds,
    }


def build_library(
    manifest: str | PathLike[str] | None,
    out: str | PathLike[str],
    blender: str | None = None,
    pack: bool = True,
    exact: str | PathLike[str] | None = None,
    runtime_table: str | PathLike[str] | None = None,
    verify: bool = False,
) -> dict[str, Any]:
    """What `lutbake blender` does: ``write_library`` (the parameters are its), then with ``verify`` every
    material rendered in Cycles and compared: the scene bake's with ``verify_library`` (key ``verify``, None
    without a manifest) and each OSL material with ``verify_osl`` (``verify_exact``, ``verify_runtime``).

    Returns ``write_library``'s document with those keys added (each check's ``ok`` says whether it is within
    RENDER_TOLERANCE); BlenderError when Blender fails, ParameterError for bad input (nothing written).
    """
    doc = write_library(manifest, out, blender, pack=pack, exact=exact, runtime_table=runtime_table)
    if not verify:
        return doc
    tables = {kind: table for kind, table in (("exact", exact), ("runtime", runtime_table)) if table is not None}
    checks: dict[str, Callable[[], dict[str, Any] | None]] = {
        "verify": lambda: verify_library(manifest, out, doc["blender"]) if manifest else None,
        **{
            f"verify_{kind}": partial(verify_osl, out, kind, tables[kind], doc["blender"])
            for kind in doc["osl_materials"]
        },
    }
    return doc | {key: check() for key, check in checks.items()}


def _exact_expected(
    table: ExactTable,
    cos_theta: np.ndarray,
    thickness_nm: np.ndarray,
    eta2: np.ndarray,
    eta3: np.ndarray,
    kappa3: np.ndarray,
) -> np.ndarray:
    """The exact mode's series in float64 (exact.exact_colour takes one film at a time)."""
    out = np.empty((len(cos_theta), 3))
    for film in np.unique(eta2):
        at = eta2 == film
        out[at] = exact_colour(table, cos_theta[at], thickness_nm[at], 1.0, film, eta3[at], kappa3[at]).values
    return out


def _runtime_expected(
    table: RuntimeTable,
    cos_theta: np.ndarray,
    thickness_nm: np.ndarray,
    eta2: np.ndarray,
    eta3: np.ndarray,
    kappa3: np.ndarray,
) -> np.ndarray:
    """The runtime include's float32 arithmetic (runtime.model): lutbake_iridescence_rgb, and at a grey base
    (equal channels) lutbake_iridescence with its one index, which the OSL script must equal there."""
    out = runtime_colour(table, cos_theta, thickness_nm, 1.0, eta2, eta3, kappa3)
    grey = (eta3 == eta3[:, :1]).all(axis=1) & (kappa3 == kappa3[:, :1]).all(axis=1)
    out[grey] = runtime_colour(
        table, cos_theta[grey], thickness_nm[grey], 1.0, eta2[grey], eta3[grey, 0], kappa3[grey, 0]
    )
    return out


# Per OSL kind: the table reader, and what the script computes at probes with η1 = 1 and η3, κ3 (n, 3) per
# channel.
_OSL_KINDS: dict[str, tuple[Callable[[str | PathLike[str]], ExactTable | RuntimeTable], Callable[..., np.ndarray]]] = {
    "exact": (read_exact_table, _exact_expected),
    "runtime": (read_runtime_table, _runtime_expected),
}
_OSL_PARAMETER = {"exact": "exact", "runtime": "runtime_table"}  # write_library's parameter of each kind


def _osl_material(kind: str) -> str:
    return OSL_MATERIALS[f"lutbake_{kind}"][0]


def osl_script(kind: str, table: str | PathLike[str], blend_folder: str | PathLike[str] | None = None) -> str:
    """The OSL script (shaders/KIND.osl.in, ``kind`` 'exact' or 'runtime') for the table ``table`` (an
    `exact-table` or `runtime-table` EXR): it reads the table at ``//`` + its path relative to
    ``blend_folder`` (the .blend's folder, which Cycles resolves ``//`` against), or at its absolute path
    without one; ValueError names a file that is not such a table."""
    read, _ = _OSL_KINDS[kind]
    path = Path(table).absolute()
    if not path.is_file():  # before OpenEXR, which prints its own line about it
        raise ParameterError(f"{{{_OSL_PARAMETER[kind]}}} {{table}} is not a file", table=repr(str(table)))
    meta = read(path).meta
    if blend_folder is None:
        return osl_source(meta, path)
    return osl_source(meta, "//" + Path(os.path.relpath(path, Path(blend_folder).absolute())).as_posix())


def read_scene(manifest: str | PathLike[str]) -> SceneReads:
    """The reads of the scene manifest at ``manifest``, read (its 4D LUTs' sidecars too) by lutbake's bounded,
    typed readers, before Blender is looked up."""
    path = Path(manifest)
    return scene_reads(path, read_scene_manifest(path), _sidecar)


def _sidecar(path: Path) -> Any:  # a JSON document: scene_reads checks what it takes
    return load_json(read_text(path, "LUT sidecar", MAX_ATTRIBUTE_BYTES), str(path))


def render_probes(job: dict[str, Any], blender: str | None = None) -> dict[str, Any]:
    """Render ``job``'s probe planes in Blender (lutbake/blender/probe.py: the job's format is there)."""
    exe = find_blender(blender)
    with tempfile.TemporaryDirectory(prefix="lutbake-blender-") as folder:
        job_path, result_path = Path(folder) / "job.json", Path(folder) / "result.json"
        job_path.write_text(json.dumps(job))
        seconds = _run(exe, "probe.py", [str(job_path), str(result_path)])
        result = json.loads(result_path.read_text())
    return {**result, "seconds": seconds}


# --- verify: a library's renders against lutbake sample --------------------------------------------


@dataclass
class Probes:
    """Probe points of one material (arrays of equal length) and what ``lutbake sample`` returns there."""

    material: str
    cos_theta: np.ndarray
    thickness_nm: np.ndarray
    eta3: np.ndarray | None  # a 4D LUT's only
    kappa3: np.ndarray | None
    expected: np.ndarray


def probe_points(scene: SceneReads, read: SliceRead | LutRead, n: int, seed: int = 0) -> Probes:
    """``n`` points of one material, every one inside the baked axes (the sampler refuses a point outside
    lutbake's domain, and an axis may start at it, e.g. a metal's η3): cos θ from grazing (0.03) to normal
    incidence, thickness over the baked range with both ends; for a 4D LUT, η3 and κ3 over the LUT's
    ranges with their ends. Expected values: the atlas sampler, or the LUT's linear rule (what the node
    groups compute: docs/blender.md)."""
    rng = np.random.default_rng(seed)
    cos_theta = np.concatenate([[1.0, 0.03], rng.uniform(0.03**0.5, 1.0, n - 2) ** 2])
    thickness = _inside(*read.thickness_nm, n, rng)
    table_path = scene.folder / read.image
    if isinstance(read, SliceRead):
        atlas = Atlas.load(table_path)
        pts = FilmPoints.build(**atlas.film_stack(read.material), cos_theta=cos_theta, thickness_nm=thickness)
        return Probes(read.material, cos_theta, thickness, None, None, atlas.sample(read.material, pts))
    lut = Lut.load(table_path)
    e, k = read.axes[2:]
    eta3, kappa3 = _inside(e["min"], e["max"], n, rng), _inside(k["min"], k["max"], n, rng)
    pts = FilmPoints.build(
        eta1=lut.eta1, eta2=lut.eta2, cos_theta=cos_theta, thickness_nm=thickness, eta3=eta3, kappa3=kappa3
    )
    return Probes(read.material, cos_theta, thickness, eta3, kappa3, lut.sample(pts, interpolation="linear"))


def _inside(low: float, high: float, n: int, rng: np.random.Generator) -> np.ndarray:
    """``n`` values in [low, high]: both ends, then uniform draws (all ``low`` when the range is one value)."""
    return np.concatenate([[low, high], rng.uniform(low, high, n - 2)]) if high > low else np.full(n, float(low))


def lutbake_probes(
    scene: SceneReads, library: str | PathLike[str], probes: list[Probes], closure: str = "glossy", first: int = 0
) -> tuple[list[dict[str, Any]], list[dict[str, Any]]]:
    """(job materials, job probes) rendering ``probes`` (one ``Probes`` per material of ``scene``) with the
    library's materials; probe material indices start at ``first``."""
    materials = [
        {
            "kind": "lutbake",
            "library": str(Path(library).absolute()),
            "material": scene.group_name(p.material),
            "closure": closure,
        }
        for p in probes
    ]
    return materials, [_probe(first + i, p, j) for i, p in enumerate(probes) for j in range(len(p.cos_theta))]


def blender_thin_film_probes(points: FilmPoints, first: int = 0) -> tuple[list[dict[str, Any]], list[dict[str, Any]]]:
    """(job materials, job probes) rendering ``points`` with Blender's own thin film: a Principled BSDF
    (film over a dielectric base of index η3) or a Metallic BSDF's Physical Conductor (per-channel n, k)
    over an absorbing one. Blender's film and base indices are constants: a named film is taken at
    549 nm, a named base at 611/549/464 nm (exact.base_rgb, the dominant wavelengths of the Rec.709
    primaries, as exact.base_rgb; the principled base at 549 nm). Probe material indices start at ``first``."""
    n = len(points)
    eta2 = (
        np.full(n, float(points.film.index(RGB_WAVELENGTHS_NM[1])[0]))
        if points.film is not None
        else np.broadcast_to(points.eta2, n)
    )
    if points.base is not None:
        eta_rgb, kappa_rgb = (np.broadcast_to(v, (n, 3)) for v in points.base.index(np.array(RGB_WAVELENGTHS_NM)))
    else:
        eta_rgb, kappa_rgb = (
            np.repeat(np.broadcast_to(v, n)[:, None], 3, axis=1) for v in (points.eta3, points.kappa3)
        )
    cos_theta, thickness = np.broadcast_to(points.cos_theta, n), np.broadcast_to(points.thickness_nm, n)
    probes = [
        {
            "material": first + int((kappa_rgb[i] > 0).any()),
            "cos_theta": float(cos_theta[i]),
            "thickness_nm": float(thickness[i]),
            "eta2": float(eta2[i]),
            "eta3": float(eta_rgb[i, 1]),
            "eta3_rgb": eta_rgb[i].tolist(),
            "kappa3_rgb": kappa_rgb[i].tolist(),
        }
        for i in range(n)
    ]
    return [{"kind": "principled"}, {"kind": "conductor"}], probes


def verify_library(
    manifest: str | PathLike[str],
    library: str | PathLike[str],
    blender: str | None = None,
    engine: str = "CYCLES",
    closure: str = "glossy",
    n_points: int = 24,
) -> dict[str, Any]:
    """Render every material of ``library`` (written by ``write_library`` for ``manifest``) at
    ``n_points`` probes in ``engine`` and compare with ``lutbake sample``.

    ``closure`` 'glossy' renders the shipped material (Glossy BSDF); 'emission' feeds the group into an
    Emission shader instead, which isolates the group from the engine's closure storage (EEVEE keeps
    closure colours in a ~10-bit G-buffer). Blender clamps a closure's negative colour components to 0
    (Cycles' Emission excepted), so the render is held to max(sample, 0). Returns per material and overall
    max |ΔRGB| (overall also in half-float ulps of the expected value: EEVEE renders into half floats),
    how many points had a negative component, the largest spread inside a probe, whether all are within
    RENDER_TOLERANCE, and the render's seconds.
    """
    scene = read_scene(manifest)
    probes = [probe_points(scene, read, n_points, seed) for seed, read in enumerate(scene.reads)]
    materials, job_probes = lutbake_probes(scene, library, probes, closure)
    result = render_probes({"engine": engine, "materials": materials, "probes": job_probes}, blender)
    rgb = np.asarray(result["rgb"]).reshape(len(probes), n_points, 3)
    expected = np.array([p.expected for p in probes])
    if closure == "glossy" or engine != "CYCLES":
        # Blender clamps a closure's negative (out-of-gamut) components to 0; Cycles' Emission passes them
        expected = np.maximum(expected, 0.0)
    errors = np.abs(rgb - expected)
    by_material = {p.material: float(errors[i].max()) for i, p in enumerate(probes)}
    worst = float(errors.max())
    clamped = sum(int((p.expected < 0).any(axis=-1).sum()) for p in probes)
    return {
        "engine": engine,
        "closure": closure,
        "blender": result["blender"],
        "points": n_points * len(probes),
        "max_abs_rgb": worst,
        "max_half_ulps": float((errors / _half_ulp(expected)).max()),
        "by_material": by_material,
        "negative_points": clamped,
        "spread_max": float(max(result["spread"])),
        "tolerance": RENDER_TOLERANCE,
        "ok": worst <= RENDER_TOLERANCE,
        "render_seconds": result["render_seconds"],
        "seconds": result["seconds"],
    }


def osl_probe_points(n_points: int, seed: int = 0) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """(cos θ, d nm, η2, η3 (n, 3), κ3 (n, 3)) of the OSL materials' probes: cos θ 0.03–1 (both ends), d
    0–1000 nm (both ends), films η2 1.2, 1.6, 2.4; every other probe a dielectric base η3 1–2.5, the others
    the metals Au, Ag, Cu, Al, Fe, Cr at their per-channel indices (611/549/464 nm)."""
    rng = np.random.default_rng(seed)
    films = (1.2, 1.6, 2.4)
    eta2 = np.repeat(films, -(-n_points // len(films)))[:n_points]
    cos_theta = np.concatenate([[1.0, 0.03], rng.uniform(0.03**0.5, 1.0, n_points - 2) ** 2])
    thickness = np.concatenate([[0.0, 1000.0], rng.uniform(0.0, 1000.0, n_points - 2)])
    metals = [np.array(material(name).index(np.array(RGB_WAVELENGTHS_NM))) for name in METALS]  # (2, 3) each
    eta3, kappa3 = np.empty((n_points, 3)), np.empty((n_points, 3))
    for j in range(n_points):
        if j % 2:
            eta3[j], kappa3[j] = metals[(j // 2) % len(metals)]
        else:
            eta3[j], kappa3[j] = rng.uniform(1.0, 2.5), 0.0
    return cos_theta, thickness, eta2, eta3, kappa3


def osl_job_probes(n_points: int, seed: int = 0, material: int = 0) -> list[dict[str, Any]]:
    """Probe.py's probes at ``osl_probe_points(n_points, seed)`` for the job's material ``material``."""
    cos_theta, thickness, eta2, eta3, kappa3 = osl_probe_points(n_points, seed)
    return [
        {
            "material": material,
            "cos_theta": float(cos_theta[j]),
            "thickness_nm": float(thickness[j]),
            "eta2": float(eta2[j]),
            "eta3_rgb": eta3[j].tolist(),
            "kappa3_rgb": kappa3[j].tolist(),
        }
        for j in range(n_points)
    ]


def verify_osl(
    library: str | PathLike[str],
    kind: str,
    table: str | PathLike[str],
    blender: str | None = None,
    n_points: int = 48,
    seed: int = 0,
) -> dict[str, Any]:
    """Render ``library``'s OSL material of ``kind`` ('exact': ``write_library(..., exact=table)``;
    'runtime': ``runtime_table=table``) in Cycles with OSL at ``osl_probe_points(n_points, seed)`` and
    compare with what the script computes in numpy (the exact mode: exact.exact_colour, float64; the
    runtime table: runtime.model's float32 model), and ΔE00 against the ground truth (channel c with the
    base's c-th index, quality.runtime_accuracy.truth; the dielectric probes alone too). All are held at 0 where
    negative, as Glossy BSDF clamps."""
    read, expected_colour = _OSL_KINDS[kind]
    cos_theta, thickness, eta2, eta3, kappa3 = osl_probe_points(n_points, seed)
    expected = np.maximum(expected_colour(read(table), cos_theta, thickness, eta2, eta3, kappa3), 0.0)
    job = {
        "engine": "CYCLES",
        "osl": True,
        "probes": osl_job_probes(n_points, seed),
        "materials": [{"kind": "lutbake", "library": str(Path(library).absolute()), "material": _osl_material(kind)}],
    }
    result = render_probes(job, blender)
    rgb = np.asarray(result["rgb"])
    errors = np.abs(rgb - expected)
    de = delta_e00(rgb, np.maximum(truth(cos_theta, thickness, eta2, eta3, kappa3), 0.0))
    dielectric = kappa3[:, 0] == 0
    return {
        "engine": "CYCLES (OSL)",
        "material": _osl_material(kind),
        "blender": result["blender"],
        "points": n_points,
        "max_abs_rgb": float(errors.max()),
        "spread_max": float(max(result["spread"])),
        "de00_max_vs_truth": float(de.max()),
        "de00_max_dielectric_vs_truth": float(de[dielectric].max()),
        "tolerance": RENDER_TOLERANCE,
        "ok": bool(errors.max() <= RENDER_TOLERANCE),
        "render_seconds": result["render_seconds"],
        "seconds": result["seconds"],
    }


def _half_ulp(values: np.ndarray) -> np.ndarray:
    """The spacing of half floats at ``values`` (normal range; 2⁻²⁴ below it)."""
    exponent = np.floor(np.log2(np.maximum(np.abs(values), 2.0**-14)))
    return 2.0 ** (exponent - 10)


def _probe(material_index: int, p: Probes, j: int) -> dict[str, Any]:
    probe = {"material": material_index, "cos_theta": float(p.cos_theta[j]), "thickness_nm": float(p.thickness_nm[j])}
    if p.eta3 is not None and p.kappa3 is not None:  # a 4D LUT's probe: both
        probe.update(eta3=float(p.eta3[j]), kappa3=float(p.kappa3[j]))
    return probe
