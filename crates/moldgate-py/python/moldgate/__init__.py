"""moldgate: where to put the injection gate of a plastic part, from its triangle mesh.

    >>> import moldgate
    >>> part = moldgate.load("cover.stl")                 # STL, OBJ, PLY (STEP/IGES with gmsh)
    >>> s = moldgate.study(part, demold="+z", material="ABS", fill=True)
    >>> s.gate.point, s.gate.distance_mm                   # numpy (3,), mm
    >>> s.report["counts"]["qualifying"]                    # the JSON report as a dict
    >>> open("cover.png", "wb").write(s.png())

A part can also come from arrays (``moldgate.Part(vertices, faces)``) or from any object
with ``.vertices`` and ``.faces`` such as a ``trimesh.Trimesh``. Every option of
:func:`study` is a field of the library's study options, named like the command line's
flags (``--gate-radius`` is ``gate_radius``) with the same defaults.

Errors are :class:`LoadError`, :class:`OptionsError` and :class:`NoGateError` (all
``ValueError``), with the library's message and place; a defect of moldgate is an
:class:`InternalError` (a ``RuntimeError``), never a crash. Loading and studying release
the GIL, so threads study parts in parallel.
"""

from __future__ import annotations

import collections.abc as _abc
import decimal as _decimal
import json as _json
import math as _math
import numbers as _numbers
import os as _os
import time as _time
from typing import Any, Iterable, Mapping, Optional, Sequence, Union

from . import _moldgate
from ._moldgate import (
    Gate,
    InternalError,
    LoadError,
    NoGateError,
    OptionsError,
    Part,
    Study,
    Suitability,
    __version__,
    sample,
)

__all__ = [
    "Gate",
    "InternalError",
    "LoadError",
    "NoGateError",
    "OptionsError",
    "Part",
    "Study",
    "Suitability",
    "batch_row",
    "check_options",
    "default_options",
    "load",
    "materials",
    "sample",
    "study",
    "STEP_EXTENSIONS",
]

#: File extensions read through gmsh (the ``step`` extra).
STEP_EXTENSIONS = (".step", ".stp", ".iges", ".igs")


def _is_step(path: Union[str, "_os.PathLike[str]"]) -> bool:
    return _os.fspath(path).lower().endswith(STEP_EXTENSIONS)


def load(
    path: Union[str, "_os.PathLike[str]"],
    units: str = "mm",
    *,
    step_tolerance_mm: Optional[float] = None,
) -> Part:
    """Reads a mesh file into a :class:`Part`.

    STL (binary or ASCII), OBJ and PLY are read by moldgate's own readers, by extension
    (STL for any other). ``units`` is the file's unit: ``mm``, ``cm``, ``m`` or ``in``.

    STEP and IGES (``.step``, ``.stp``, ``.iges``, ``.igs``) are tessellated by gmsh,
    installed with ``pip install "moldgate[step]"``; their coordinates come out in mm
    whatever unit the file declares, so ``units`` must stay ``"mm"``.
    ``step_tolerance_mm`` is the largest triangle edge, in mm (gmsh's
    ``Mesh.MeshSizeMax``; default: the part's diagonal / 50); curved faces also get at
    least 24 triangles per full turn (``Mesh.MeshSizeFromCurvature``), so they follow
    the shape at any size.

    Raises :class:`LoadError` (with the file and place) for a file that cannot be read.
    """
    _check_units_type(units)
    path = _path_text(path, "path", TypeError)
    if _is_step(path):
        from . import _step

        if units.lower() != "mm":
            raise OptionsError(
                f"units: a STEP or IGES file carries its own unit and is read in mm; got {units!r}"
            )
        started = _time.perf_counter()
        vertices, faces = _step.tessellate(_os.fspath(path), step_tolerance_mm)
        return _step.part_from_tessellation(path, vertices, faces, _time.perf_counter() - started)
    if step_tolerance_mm is not None:
        raise OptionsError("step_tolerance_mm applies to STEP and IGES files only")
    return _moldgate.load(_os.fspath(path), units)


def _path_text(value: Any, name: str, error: type = OptionsError) -> Optional[str]:
    """A path given as text or an ``os.PathLike`` of text, as text (``None`` stays
    ``None``); anything else, bytes included, raises ``error`` naming ``name``."""
    if value is None:
        return None
    text = _os.fspath(value) if isinstance(value, _os.PathLike) else value
    if not isinstance(text, str):
        raise error(f"{name} must be text or a path (str or os.PathLike), got {type(text).__name__}")
    return text


def _check_units_type(units: Any) -> None:
    """A unit given as anything but text is an :class:`OptionsError`, as an unknown one is."""
    if not isinstance(units, str):
        raise OptionsError(f"units must be one of mm, cm, m, in; got {units!r}")


def default_options() -> dict:
    """The default study options (the command line's defaults), as a dict."""
    return _json.loads(_moldgate.default_options())


def _is_number(v: Any) -> bool:
    """A real number, Python's or numpy's (``np.int64``, ``np.float32``) or a ``Decimal``,
    not a bool."""
    return isinstance(v, (_numbers.Real, _decimal.Decimal)) and not isinstance(v, bool)


def _point_text(point: Any) -> Any:
    """A gate point as the library reads it: ``"x,y,z"`` text, or a sequence of numbers
    written exactly (``repr``), so that a bad value meets the library's own message."""
    if isinstance(point, str):
        return point
    try:
        values = list(point.tolist() if hasattr(point, "tolist") else point)
    except TypeError:
        return str(point)
    # A Decimal NaN or infinity (a signalling NaN has no float) is left as its text.
    exact = lambda v: _is_number(v) and not (isinstance(v, _decimal.Decimal) and not v.is_finite())
    return ",".join(repr(float(v)) if exact(v) else str(v) for v in values)


def _options_json(options: Mapping[str, Any]) -> str:
    options = dict(options)
    # An iterator (a generator) is read once and would be half used by the checks below:
    # refused by its name, as a value of no option's kind.
    for name, value in options.items():
        if isinstance(value, _abc.Iterator):
            raise OptionsError(_not_an_option_value(name, value))
    # A direction as numbers (a list, a tuple, a numpy array) is the "x,y,z" text: three
    # of them read, any other count or a value that is not a number meets the library's
    # message for a direction ("expected three numbers"), not one about JSON types.
    for name in ("demold", "cosmetic"):
        d = options.get(name)
        if (
            d is not None and not isinstance(d, (str, bytes, Mapping))
            and (hasattr(d, "__len__") or hasattr(d, "tolist"))
        ):
            options[name] = _point_text(d)
    gate_at = options.get("gate_at")
    if gate_at is not None:
        if isinstance(gate_at, str) or (
            hasattr(gate_at, "__len__") and len(gate_at) == 3
            and all(_is_number(v) for v in gate_at)
        ):
            gate_at = [gate_at]
        elif hasattr(gate_at, "__len__") and len(gate_at) > 0 and all(_is_number(v) for v in gate_at):
            raise OptionsError(
                f"gate_at: give points (x, y, z) in mm, one or a list of them; got a flat list of {len(gate_at)} numbers"
            )
        elif not hasattr(gate_at, "__iter__"):
            raise OptionsError(
                f"gate_at: give points (x, y, z) in mm, one or a list of them; got {gate_at!r}"
            )
        options["gate_at"] = [_point_text(p) for p in gate_at]
    if "keep_out" in options and options["keep_out"] is None:
        options["keep_out"] = []
    if isinstance(options.get("keep_out"), str):
        options["keep_out"] = [options["keep_out"]]
    elif options.get("keep_out") is not None and not isinstance(options["keep_out"], list):
        try:
            options["keep_out"] = list(options["keep_out"])
        except TypeError:
            raise OptionsError(
                "keep_out: expected a region (\"box:...\" or \"sphere:...\") or a list of them, "
                f"got {options['keep_out']!r}"
            ) from None
    plain = {name: _json_value(name, value) for name, value in options.items()}
    return _json.dumps(plain, allow_nan=False)


def _json_value(name: str, value: Any) -> Any:
    """An option's value as JSON takes it: numpy's scalars and arrays and a ``Decimal`` as
    plain numbers and lists. JSON has no NaN or infinity, the options' integers fit 64
    bits, and a value of no option's kind (a generator, an object) is refused: each said
    here by the option's name (a material's parameter as ``material.n``), not as a JSON
    writer's complaint about a value."""
    if value is None or isinstance(value, (bool, str)):
        return value
    if isinstance(value, _numbers.Integral):
        if not -(2**63) <= int(value) < 2**64:
            raise OptionsError(f"{name} is out of range, got {value}")
        return int(value)
    if isinstance(value, _decimal.Decimal) and not value.is_finite():
        raise OptionsError(f"{name} must be a finite number, got {value}")
    if isinstance(value, (_numbers.Real, _decimal.Decimal)):
        if not _math.isfinite(float(value)):
            raise OptionsError(f"{name} must be a finite number, got {value}")
        return float(value)
    if isinstance(value, Mapping):
        return {k: _json_value(f"{name}.{k}", v) for k, v in value.items()}
    if hasattr(value, "tolist"):
        return _json_value(name, value.tolist())
    if isinstance(value, (list, tuple)):
        return [_json_value(name, v) for v in value]
    raise OptionsError(_not_an_option_value(name, value))


def _not_an_option_value(name: str, value: Any) -> str:
    kind = type(value).__name__
    article = "an" if kind[:1].lower() in "aeiou" else "a"
    return (
        f"{name}: {article} {kind} is not an option value "
        "(give a number, text, True or False, or a list of them)"
    )


def _check_part_keywords(units: Any, step_tolerance_mm: Any) -> None:
    """The keywords that say how the part is read, checked as :func:`study` reads them."""
    _check_units_type(units)
    _moldgate.check_units(units)
    if step_tolerance_mm is not None and not (
        _is_number(step_tolerance_mm) and _math.isfinite(step_tolerance_mm) and step_tolerance_mm > 0
    ):
        raise OptionsError(f"step_tolerance_mm must be a positive number of mm, got {step_tolerance_mm!r}")


def _check_run_keywords(allow_no_gate: Any, timeout: Any) -> None:
    """The keywords that say how a study runs, checked before it starts."""
    if not isinstance(allow_no_gate, bool):
        raise OptionsError(f"allow_no_gate must be True or False, got {allow_no_gate!r}")
    if timeout is not None and (isinstance(timeout, bool) or not isinstance(timeout, _numbers.Real)):
        raise OptionsError(f"timeout must be a number of seconds or None, got {timeout!r}")


class _DefaultUnits(str):
    """The default of ``units`` (mm), told apart from ``units="mm"`` given by the caller."""


_MM = _DefaultUnits("mm")


def _part(part: Any, units: str, step_tolerance_mm: Optional[float]) -> Part:
    _check_part_keywords(units, step_tolerance_mm)
    if isinstance(part, Part):
        # A Part was read in its own units: another unit asked for here would be ignored,
        # so a unit given (not the default) must be the Part's own.
        own = part.stats["units"]
        if units is not _MM and units.lower() != own:
            raise OptionsError(
                f"units: this Part was read in {own}; units={units!r} applies to a path or "
                f"arrays only: read the file again with moldgate.load(path, units={units!r})"
            )
    if step_tolerance_mm is not None and not isinstance(part, (str, _os.PathLike)):
        # Read already (or not a file): the tolerance would be ignored without a word.
        raise OptionsError(
            "step_tolerance_mm applies to a STEP or IGES file given by its path; this part is "
            f"a {type(part).__name__}: load the file with moldgate.load(path, step_tolerance_mm=...)"
        )
    if isinstance(part, Part):
        return part
    if isinstance(part, (str, _os.PathLike)):
        return load(part, units, step_tolerance_mm=step_tolerance_mm)
    return Part.from_trimesh(part, units)


# The options of a study, with the command line's defaults (a test checks them against
# the library's). Keep the signature of `study` in step with this list.
_OPTION_NAMES = (
    "demold", "material", "n", "t_melt", "t_wall", "gamma_opt", "mu_opt", "k",
    "gate_radius", "spacing", "grid_offset", "circle_points", "centre", "nearest",
    "thickness_rule", "require_flat", "flat_tol", "aesthetic", "max_nodes", "keep_out",
    "cosmetic", "fill", "strategy", "objective", "gates", "cell", "wall_thickness",
    "color_by", "fit_radius", "parting_line", "gate_at", "suitability",
)


def study(
    part: Union[Part, str, "_os.PathLike[str]", Any],
    *,
    demold: str = "+z",
    material: Union[str, Mapping[str, Any]] = "PP",
    n: Optional[float] = None,
    t_melt: Optional[float] = None,
    t_wall: Optional[float] = None,
    gamma_opt: Optional[float] = None,
    mu_opt: Optional[float] = None,
    k: Optional[float] = None,
    gate_radius: Optional[float] = None,
    spacing: Optional[float] = None,
    grid_offset: float = 0.0,
    circle_points: int = 16,
    centre: str = "surface",
    nearest: str = "3d",
    thickness_rule: str = "require",
    require_flat: bool = False,
    flat_tol: Optional[float] = None,
    aesthetic: bool = False,
    max_nodes: int = 4000000,
    keep_out: Sequence[str] = (),
    cosmetic: Optional[str] = None,
    fill: bool = False,
    strategy: str = "paper",
    objective: str = "length",
    gates: int = 1,
    cell: Optional[float] = None,
    wall_thickness: bool = False,
    color_by: str = "fill_order",
    fit_radius: bool = False,
    parting_line: str = "outline",
    gate_at: Sequence[Union[str, Sequence[float]]] = (),
    suitability: bool = False,
    units: str = _MM,
    materials_file: Optional[Union[str, "_os.PathLike[str]"]] = None,
    step_tolerance_mm: Optional[float] = None,
    allow_no_gate: bool = False,
    timeout: Optional[float] = None,
    **unknown: Any,
) -> Study:
    """Studies a part: the gate of the paper's method, and what was asked for on top.

    ``part`` is a :class:`Part`, a path (read by :func:`load` in ``units``), or any
    object with ``.vertices`` and ``.faces`` (a ``trimesh.Trimesh``, read in place).

    Options (the command line's ``locate`` flags in snake case, same defaults):

    - ``demold="+z"``: demolding direction, ``+x``, ``-y``, ... or ``"x,y,z"`` (or three
      numbers: a list, a tuple or a numpy array); ``"auto"``
      picks the axis or principal axis with the least undercut.
    - ``material="PP"``: a built-in (``PP``, ``ABS``, ``PC``, see :func:`materials`), a
      name from ``materials_file``, or a dict of every parameter (``n``, ``t_melt``,
      ``t_wall``, ``gamma_opt``, ``mu_opt``, ``k``; optional ``name``,
      ``max_flow_ratio``).
    - ``n``, ``t_melt``, ``t_wall``, ``gamma_opt``, ``mu_opt``, ``k`` (None): overrides of
      one material parameter (SI units, temperatures in C).
    - ``gate_radius=None``: R_gate in mm instead of Eq. 8.
    - ``spacing=None``: grid spacing, mm (default min(R_gate, longest side / 100)).
    - ``grid_offset=0.0``: grid shift as a fraction of the spacing.
    - ``circle_points=16``: points on each node's circle.
    - ``centre="surface"``: ``surface`` (Eq. 5) or ``volume`` centre of mass.
    - ``nearest="3d"``: ``3d`` or ``2d`` (in the projection plane) distance to it.
    - ``thickness_rule="require"``: ``require`` (walls thicker than R_gate) or ``ignore``.
    - ``require_flat=False``, ``flat_tol=None``: only flat circles (within 0.1 R_gate).
    - ``aesthetic=False``: the gate on the parting line.
    - ``parting_line="outline"``: ``outline`` (the closed outer rim of each body seen
      along D) or ``longest`` (the longest loop of the edges between the two sides).
    - ``max_nodes=4000000``: largest grid accepted.
    - ``keep_out=()``: regions no gate may reach, ``"box:x0,y0,z0,x1,y1,z1"`` or
      ``"sphere:x,y,z,r"`` (mm).
    - ``cosmetic=None``: the visible side (a direction): no gate on faces turned to it.
    - ``fill=False``: the fill analysis (flow length, fill order, Eq. 1 pressure, weld
      lines, balanced gate); implied by ``strategy="balanced"`` and ``gates > 1``.
    - ``strategy="paper"``: ``paper`` or ``balanced`` (the gate minimising the objective).
    - ``objective="length"``: ``length`` or ``resistance``.
    - ``gates=1``: number of gates that together minimise the worst flow (1 to the library's limit).
    - ``cell=None``: flow-analysis cell size, mm.
    - ``wall_thickness=False``: measure the wall thickness everywhere.
    - ``color_by="fill_order"``: what pictures of the fill are coloured by:
      ``fill_order`` (the estimated fill time), ``flow_length``, ``wall`` or ``height``.
    - ``fit_radius=False``: when the paper's thickness rule removes every node, take the
      largest gate radius that fits instead of answering with no gate.
    - ``gate_at=()``: gates you place, each ``(x, y, z)`` in mm in the part's frame (or
      ``"x,y,z"``), at most 32: each is moved to the nearest surface point and judged by
      the paper's rules; with ``fill=True`` they are filled together as one layout.
      ``.report["placed_gates"]`` has the verdicts (docs/json-schema.md).
    - ``suitability=False``: score every qualifying node as a gate (the gate-suitability
      map: the objective of the balanced gate at each node, exact or a lower bound; implies
      ``fill``); read it as :attr:`Study.suitability`, and the pictures show it.

    And for this call:

    - ``units="mm"``: unit of a path or arrays given as ``part`` (a :class:`Part` keeps
      the unit it was read in; a unit given with it other than its own is refused).
    - ``materials_file=None``: a TOML file of user materials (the command line's
      ``--materials-file``).
    - ``step_tolerance_mm=None``: see :func:`load`.
    - ``allow_no_gate=False``: when no position qualifies, return the study (its ``gate``
      is None and ``report["no_gate_reason"]`` says why) instead of raising
      :class:`NoGateError`. A layout of ``gates=K`` that finds too few positions has no
      study to return and raises :class:`NoGateError` either way.
    - ``timeout=None``: a time limit in seconds; past it the study is stopped and the
      built-in ``TimeoutError`` raised. Ctrl-C (``KeyboardInterrupt``) stops a study too,
      whether or not it has a time limit. Both are looked for every 50 ms, and the study
      stops within a step of it then (a march of the fill, a facet of a wall map, a block
      of triangles of the gate's rays; the loading of a file runs to its end). A study that
      ends before the look that finds its limit passed is returned.

    An unknown option name or a bad value raises :class:`OptionsError` with the
    library's message.
    """
    given = locals()
    _check_run_keywords(allow_no_gate, timeout)
    options = {name: given[name] for name in _OPTION_NAMES}
    # A region, a sequence of them or None: read by `_options_json`.
    options["keep_out"] = keep_out
    options.update(unknown)
    options_json = _options_json(options)
    p = _part(part, units, step_tolerance_mm)
    mf = _path_text(materials_file, "materials_file")
    s = _moldgate.study(p, options_json, mf, None if timeout is None else float(timeout))
    if s.gate is None and not allow_no_gate:
        reason = s.report.get("no_gate_reason") or "no position qualifies for a gate"
        raise NoGateError(f"{p.path or 'part'}: {_moldgate.keyword_words(reason)}")
    return s


def batch_row(
    path: Union[str, "_os.PathLike[str]"],
    *,
    units: str = "mm",
    materials_file: Optional[Union[str, "_os.PathLike[str]"]] = None,
    timeout: Optional[float] = None,
    **options: Any,
) -> dict:
    """Loads and studies one file and gives its row of a batch summary: the row that
    ``moldgate locate DIR --summary x.jsonl`` writes for it (``file``, ``status``,
    ``exit_code``, ``units``, ``demold``, ``triangles``, the gate, ``distance_mm``,
    ``gate_radius_mm``, the counts, ``time_s``, ``error``).

    A part that fails (a file that cannot be read, no gate) is a row with its status and
    reason, never an exception; refused options raise :class:`OptionsError`, since they
    would fail every part. ``options`` are those of :func:`study`. It reads the files the
    command line reads (STL, OBJ, PLY): a STEP or IGES file is a failed row, as in the
    command line's batch, with what to do; :func:`study` and :func:`load` tessellate them.
    ``timeout=SECONDS`` stops a study past that time: its row has status ``timeout`` (exit
    code 6) and says so, as the command line's batch gives for ``--timeout``; stopped after
    the gate was located, it keeps the method's gate found before the stop when that is the
    answer asked for (no balanced gate nor layout).
    """
    _check_units_type(units)
    if timeout is not None and (isinstance(timeout, bool) or not isinstance(timeout, _numbers.Real)):
        raise OptionsError(f"timeout must be a number of seconds or None, got {timeout!r}")
    mf = _path_text(materials_file, "materials_file")
    return _json.loads(
        _moldgate.batch_row(
            _path_text(path, "path", TypeError), _options_json(options), mf, units, None,
            None if timeout is None else float(timeout),
        )
    )


def check_options(
    *,
    materials_file: Optional[Union[str, "_os.PathLike[str]"]] = None,
    units: str = "mm",
    step_tolerance_mm: Optional[float] = None,
    allow_no_gate: bool = False,
    timeout: Optional[float] = None,
    **options: Any,
) -> None:
    """Checks study options (those of :func:`study`, ``units``, ``step_tolerance_mm``,
    ``allow_no_gate`` and ``timeout`` included) without a part: raises
    :class:`OptionsError` with the library's message for an unknown name or a bad value."""
    _check_part_keywords(units, step_tolerance_mm)
    _check_run_keywords(allow_no_gate, timeout)
    mf = _path_text(materials_file, "materials_file")
    _moldgate.check_options(_options_json(options), mf, None if timeout is None else float(timeout))


def materials(materials_file: Optional[Union[str, "_os.PathLike[str]"]] = None) -> list:
    """The built-in materials (the paper's Table 1 first, then the typical grades, as
    ``moldgate materials`` lists them), each replaced by a material of ``materials_file``
    (TOML, one table per material) of the same name or alias, then that file's other
    materials; each a dict as ``moldgate materials --json`` gives it: its parameters, the
    melt velocity (Eq. 7, ``melt_velocity_m_s``) and the gate radius (Eq. 8,
    ``gate_radius_mm``), its ``aliases``, ``description``, ``family``, whether its values
    are ``typical`` of the family, the ``sources`` of each value, and its ``origin``
    (``"built-in"`` or the file's path)."""
    mf = _path_text(materials_file, "materials_file")
    return _moldgate.materials(mf)
