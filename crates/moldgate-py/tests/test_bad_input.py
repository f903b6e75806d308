"""Bad input: each case a clear exception with the library's message and place."""

import struct

import numpy as np
import pytest

import moldgate

V = np.array([[0.0, 0, 0], [10, 0, 0], [0, 10, 0], [0, 0, 10]])
F = np.array([[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]])


@pytest.mark.parametrize(
    "vertices, faces, message",
    [
        (V[:, :2], F, r"vertices must be an \(n, 3\) array, got shape \[4, 2\]"),
        (V.ravel(), F, r"vertices must be an \(n, 3\) array, got shape \[12\]"),
        (V, F[:, :2], r"faces must be an \(m, 3\) array"),
        (V, F.reshape(2, 2, 3), r"faces must be an \(m, 3\) array"),
        (V, F.astype(float), "faces must be an integer array, got float64"),
        (V, F.astype(bool), "faces must be an integer array, got bool"),
        (V.astype(str), F, "vertices must be numbers"),
        ([[0, 0, "a"]] * 4, F, "vertices must be numbers"),
    ],
)
def test_wrong_shape_or_dtype(vertices, faces, message):
    with pytest.raises(moldgate.LoadError, match=message):
        moldgate.Part(vertices, faces)


@pytest.mark.parametrize("value", [np.nan, np.inf, -np.inf])
def test_non_finite_coordinates_name_the_vertex(value):
    v = V.copy()
    v[2, 1] = value
    with pytest.raises(moldgate.LoadError, match=rf"vertex 2 has a non-finite coordinate \({'NaN' if np.isnan(value) else ''}"):
        moldgate.Part(v, F)


@pytest.mark.parametrize("value", [1.1e9, -1e307])
def test_coordinates_beyond_the_files_limit_name_the_vertex(value):
    v = V.copy()
    v[2, 1] = value
    with pytest.raises(moldgate.LoadError, match=r"vertex 2: a coordinate of .* is beyond the limit of ±1e9 mm"):
        moldgate.Part(v, F)


@pytest.mark.parametrize("bad", [4, 1000, -1])
def test_face_indices_out_of_range_name_the_triangle(bad):
    f = F.copy()
    f[3, 1] = bad
    with pytest.raises(moldgate.LoadError, match=rf"triangle 3 uses vertex {bad}, outside the 4 vertices \(0 to 3\)"):
        moldgate.Part(V, f)


def test_unsigned_indices_beyond_int64():
    f = F.astype(np.uint64)
    f[2, 1] = np.iinfo(np.uint64).max
    with pytest.raises(moldgate.LoadError, match=f"triangle 2 uses vertex {np.iinfo(np.uint64).max}, beyond any vertex"):
        moldgate.Part(V, f)


def test_an_empty_part():
    with pytest.raises(moldgate.LoadError, match=r"no facet has a non-zero area \(0 facets read\)"):
        moldgate.Part(np.zeros((0, 3)), np.zeros((0, 3), dtype=np.int64))
    with pytest.raises(moldgate.LoadError, match="no facet has a non-zero area"):
        moldgate.Part(V, [[0, 1, 1]])


def test_an_object_without_arrays():
    with pytest.raises(moldgate.LoadError, match="cannot study a int"):
        moldgate.study(42)


@pytest.mark.parametrize(
    "options, message",
    [
        ({"gate_raduis": 2.0}, r"unknown field `gate_raduis` \(did you mean `gate_radius`\?\), expected one of `demold`"),
        ({"gates": 0}, "gates must be at least 1"),
        ({"gates": 65}, r"gates must be at most \d+, got 65"),
        ({"gates": 1.5}, "gates: got the decimal number 1.5, expected a whole number of 1 or more"),
        ({"gates": -1}, "gates: got -1, expected a whole number of 1 or more"),
        ({"gates": "3"}, 'gates: got the text "3", expected a whole number of 1 or more'),
        ({"spacing": "1"}, 'spacing: got the text "1", expected a number'),
        ({"fill": None}, "fill: got None, expected a boolean"),
        ({"material": 3}, "material: .*expected a material name or a table of its parameters"),
        ({"material": {"n": "x"}}, 'material.n: got the text "x", expected a number'),
        ({"demold": "sideways"}, "demold: cannot read direction 'sideways'"),
        ({"demold": "0,0,0"}, "demold: a direction must be a non-zero"),
        # Numbers of a direction in a list of the wrong length, or not numbers: the
        # direction's own message (it said "got a list, expected a string").
        ({"demold": [0, 0, 1, 0]}, "demold: cannot read direction '0.0,0.0,1.0,0.0': expected"),
        ({"demold": ["0", "0", "x"]}, "demold: cannot read direction '0,0,x'"),
        ({"demold": np.array([0, 1])}, "demold: cannot read direction '0.0,1.0': expected"),
        ({"grid_offset": 1.5}, "grid_offset must be a fraction of the spacing, above -1 and below 1, got 1.5"),
        # Advice names this package's arguments, not the command line's flags.
        ({"spacing": 1e-9}, r"or raise the node limit \(max_nodes\)$"),
        # A library limit is led by the keyword it is about.
        ({"circle_points": 10**7}, r"^circle_points: circle points must be at most 360, got 10000000$"),
        ({"material": "WOOD"}, r"unknown material 'WOOD'"),
        ({"strategy": "best"}, "unknown variant `best`, expected `paper` or `balanced`"),
        ({"keep_out": ["cube:1,2,3"]}, "keep_out: cannot read keep-out region 'cube:1,2,3'"),
        ({"spacing": -1.0}, "spacing must be a positive number, got -1"),
        ({"spacing": float("nan")}, "spacing must be a finite number, got nan"),
        ({"gate_radius": float("inf")}, "gate_radius must be a finite number, got inf"),
        ({"gate_radius": 1e300}, "gate_radius must be from 0.001 to 1000 mm, got 1.000e300"),
        ({"gate_radius": 1e-9}, "gate_radius must be from 0.001 to 1000 mm, got 1.000e-9"),
        (
            {"material": {"n": float("nan"), "t_melt": 230, "t_wall": 50, "gamma_opt": 1e4, "mu_opt": 10, "k": 0.15}},
            "material.n must be a finite number, got nan",
        ),
        ({"max_nodes": 2**70}, "max_nodes is out of range, got 1180591620717411303424"),
        # numpy's scalars are checked as Python's are, each by its name.
        ({"n": np.float32("nan")}, "^n must be a finite number, got nan$"),
        ({"gate_radius": np.float32("inf")}, "^gate_radius must be a finite number, got inf$"),
        (
            {"material": {"n": np.float32("nan"), "t_melt": 230, "t_wall": 50, "gamma_opt": 1e4, "mu_opt": 10, "k": 0.15}},
            "^material.n must be a finite number, got nan$",
        ),
        # A value of no option's kind is refused by its name.
        ({"demold": (x for x in (0, 0, 1))}, r"^demold: a generator is not an option value \(give a number"),
        ({"keep_out": [object()]}, r"^keep_out: an object is not an option value"),
        ({"max_nodes": 0}, "max_nodes must be between 1 and"),
        ({"n": -0.3}, "n must be a positive finite number, got -0.3"),
        ({"units": "furlong"}, "units: unknown unit 'furlong'"),
        ({"fill": "yes"}, "got the text \"yes\", expected a boolean"),
        ({"strategy": 1}, "strategy: got the number 1, expected `paper` or `balanced`"),
        ({"gate_at": 5}, r"gate_at: give points \(x, y, z\) in mm, one or a list of them; got 5"),
        ({"objective": True}, "objective: got True, expected `length` or `resistance`"),
        ({"material": {"n": None}}, r"material.n: got None, expected a number"),
        ({"circle_points": 2.5}, "circle_points: got the decimal number 2.5, expected a whole number of 3 or more"),
        ({"keep_out": 5}, r"keep_out: expected a region \(\"box:...\" or \"sphere:...\"\) or a list of them, got 5"),
        ({"gate_at": [(1, 2)]}, r"gate_at 1 '1.0,2.0': expected x,y,z \(three numbers in mm\), got 2 values"),
        ({"gate_at": ["a,b,c"]}, "gate_at 1 'a,b,c': x is not a number"),
        ({"gate_at": [(1, float("nan"), 0)]}, "gate_at 1 '1.0,nan,0.0': y must be a finite number"),
        ({"gate_at": [(1, 2, float("inf"))]}, "gate_at 1 '1.0,2.0,inf': z must be a finite number"),
        ({"gate_at": [(0, 0, 3)] * 33}, "gate_at is given 33 times, over the limit of 32 gates"),
        ({"gate_at": [(0, 0, 300)]}, r"gate_at 1 \(0.000, 0.000, 300.000\) is 297.000 mm from the part's surface"),
    ],
)
def test_unknown_option_name_or_value(options, message):
    with pytest.raises(moldgate.OptionsError, match=message):
        moldgate.study(moldgate.sample("plate"), **options)


def test_numbers_of_numpy_and_decimal_are_numbers():
    from decimal import Decimal

    plate = moldgate.sample("plate")
    same = moldgate.study(plate, gate_radius=1.5, spacing=2.0).gate.point
    for radius, spacing in ((Decimal("1.5"), Decimal("2")), (np.float32(1.5), np.int64(2))):
        assert np.array_equal(moldgate.study(plate, gate_radius=radius, spacing=spacing).gate.point, same)
    with pytest.raises(moldgate.OptionsError, match="^gate_radius must be a finite number, got NaN$"):
        moldgate.study(plate, gate_radius=Decimal("NaN"))
    with pytest.raises(moldgate.OptionsError, match="^cell must be a finite number, got sNaN$"):
        moldgate.study(plate, cell=Decimal("sNaN"))
    # A point of Decimals is one point, as one of floats is.
    placed = lambda s: s.report["placed_gates"]["gates"]
    on = placed(moldgate.study(plate, gate_at=[0.0, 0.0, 4.0]))
    assert on == placed(moldgate.study(plate, gate_at=[Decimal(0), Decimal(0), Decimal(4)]))
    with pytest.raises(moldgate.OptionsError, match=r"gate_at 1 '1.0,sNaN,0.0': y"):
        moldgate.study(plate, gate_at=[Decimal(1), Decimal("sNaN"), Decimal(0)])
    # An iterator is refused by its name, whichever option it is given to.
    for name in ("gate_at", "keep_out", "demold"):
        with pytest.raises(moldgate.OptionsError, match=f"^{name}: a generator is not an option value"):
            moldgate.study(plate, **{name: (x for x in (1, 2, 3))})
    with pytest.raises(moldgate.OptionsError, match="^material: an object is not an option value"):
        moldgate.study(plate, material=object())


def test_a_step_tolerance_with_a_part_already_read_is_refused():
    with pytest.raises(moldgate.OptionsError, match="^step_tolerance_mm applies to a STEP or IGES file given by its path; this part is a Part"):
        moldgate.study(moldgate.sample("plate"), step_tolerance_mm=1.0)


def test_a_missing_file_is_named(tmp_path):
    missing = tmp_path / "nope.stl"
    with pytest.raises(moldgate.LoadError, match=rf"{missing}: cannot open: No such file"):
        moldgate.load(missing)
    with pytest.raises(moldgate.LoadError, match="is a folder, not a mesh file"):
        moldgate.study(tmp_path)


def test_a_bad_mesh_file_names_its_place(tmp_path):
    bad = tmp_path / "bad.obj"
    bad.write_text("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 9\n")
    with pytest.raises(moldgate.LoadError, match=rf"{bad}: line 4"):
        moldgate.load(bad)
    empty = tmp_path / "empty.stl"
    empty.write_bytes(b"")
    with pytest.raises(moldgate.LoadError, match="empty file"):
        moldgate.load(empty)


@pytest.mark.skipif(not hasattr(__import__("os"), "mkfifo"), reason="no FIFOs on this system")
def test_a_fifo_or_a_device_is_refused_without_reading(tmp_path):
    import os

    fifo = tmp_path / "pipe.stl"
    os.mkfifo(fifo)
    # Opened for reading, a FIFO would wait for a writer forever.
    with pytest.raises(moldgate.LoadError, match="pipe.stl: is a FIFO, not a mesh file"):
        moldgate.load(fifo)
    with pytest.raises(moldgate.OptionsError, match="pipe.stl: is a FIFO, not a TOML file"):
        moldgate.study(moldgate.sample("plate"), materials_file=fifo)
    if os.path.exists("/dev/zero"):
        # Endless zeros: refused by what the file is, not read until memory runs out.
        with pytest.raises(moldgate.OptionsError, match="is a character device, not a TOML file"):
            moldgate.study(moldgate.sample("plate"), materials_file="/dev/zero")


def test_a_materials_file_over_its_limit_or_not_utf8_is_refused(tmp_path):
    big = tmp_path / "big.toml"
    with open(big, "wb") as f:
        f.truncate(3 << 30)  # sparse: refused by its size, not read
    with pytest.raises(moldgate.OptionsError, match=r"big\.toml: is over the limit of 1 MiB for a TOML file \(3 GiB\)"):
        moldgate.study(moldgate.sample("plate"), materials_file=big)
    latin = tmp_path / "latin.toml"
    latin.write_bytes(b"[X]\n# caf\xe9\n")
    with pytest.raises(moldgate.OptionsError, match=r"latin\.toml: line 2: not UTF-8 text \(byte 9 of the file\)"):
        moldgate.study(moldgate.sample("plate"), materials_file=latin)


def test_numpy_numbers_and_none_read_as_python_ones():
    part = moldgate.sample("plate")
    # A point of whole millimetres near the paper's gate, as Python floats, then as numpy
    # numbers of several dtypes and as a 1-D array: one point each time.
    x, y, z = (float(round(c)) for c in moldgate.study(part).gate.point)
    want = moldgate.study(part, gate_at=[(x, y, z)]).report["placed_gates"]
    for point in (np.array([x, y, z]).astype(np.int64), np.array([x, y, z], np.float32),
                  [np.int64(x), np.float32(y), z]):
        assert moldgate.study(part, gate_at=point).report["placed_gates"] == want
    # No keep-out regions, said as None.
    assert moldgate.study(part, keep_out=None).report["gate"] == moldgate.study(part).report["gate"]
    moldgate.check_options(keep_out=None)


def test_check_options_takes_every_keyword_of_study_and_checks_it_alike():
    # The keywords of how a part is read and how a study runs are study's too.
    moldgate.check_options(units="in", step_tolerance_mm=0.01, allow_no_gate=True, timeout=5)
    for bad in (dict(units="furlong"), dict(units=3), dict(step_tolerance_mm=-1),
                dict(allow_no_gate="yes"), dict(timeout="soon"), dict(timeout=0),
                dict(timeout=float("nan"))):
        with pytest.raises(moldgate.OptionsError) as checked:
            moldgate.check_options(**bad)
        with pytest.raises(moldgate.OptionsError) as studied:
            moldgate.study(moldgate.sample("plate"), **bad)
        assert str(checked.value) == str(studied.value), bad


def test_materials_lists_the_whole_built_in_library():
    names = [m["name"] for m in moldgate.materials()]
    assert names[:3] == ["PP", "ABS", "PC"]
    assert len(names) > 3 and len(set(names)) == len(names)
    # Every listed material is one a study takes.
    for name in names:
        moldgate.check_options(material=name)


def test_units_and_flags_of_the_wrong_type_are_options_errors():
    part = moldgate.sample("plate")
    for call in (lambda: moldgate.load("x.stl", units=None), lambda: moldgate.load("x.step", units=5),
                 lambda: moldgate.study(part, units=None), lambda: moldgate.batch_row("x.stl", units=None),
                 lambda: moldgate.Part(np.zeros((3, 3)), np.array([[0, 1, 2]]), units=None),
                 lambda: moldgate.Part(np.zeros((3, 3)), np.array([[0, 1, 2]]), None),
                 lambda: moldgate.Part.from_trimesh(part, units=1.0)):
        with pytest.raises(moldgate.OptionsError, match="units must be one of mm, cm, m, in; got"):
            call()
    with pytest.raises(moldgate.OptionsError, match="allow_no_gate must be True or False, got 'x'"):
        moldgate.study(part, allow_no_gate="x")


def test_units_given_with_a_part_read_in_other_units_are_refused():
    part = moldgate.sample("plate")  # in mm
    with pytest.raises(moldgate.OptionsError, match="this Part was read in mm; units='m' applies to a path or arrays only"):
        moldgate.study(part, units="m")
    # The default, and the Part's own unit, are fine.
    assert moldgate.study(part).gate is not None
    assert moldgate.study(part, units="mm").gate is not None
    # mm given with a Part read in inches is refused too (it is not the default).
    inches = moldgate.Part(part.vertices / 25.4, part.faces, units="in")
    assert moldgate.study(inches).gate is not None
    assert moldgate.study(inches, units="in").gate is not None
    with pytest.raises(moldgate.OptionsError, match="this Part was read in in; units='mm' applies to a path or arrays only"):
        moldgate.study(inches, units="mm")


def test_errors_belong_to_the_package_and_name_its_keywords():
    # Tracebacks read moldgate.OptionsError, not the extension module's name.
    for e in (moldgate.LoadError, moldgate.OptionsError, moldgate.NoGateError):
        assert e.__module__ == "moldgate", e.__module__
    # A part with no gate: the reason's advice names keywords (aesthetic=True), not flags.
    everything = "box:-1000,-1000,-1000,1000,1000,1000"
    with pytest.raises(moldgate.NoGateError) as e:
        moldgate.study(moldgate.sample("plate"), keep_out=[everything])
    assert "--" not in str(e.value), str(e.value)
    # A part in metres read as millimetres: the warning names the units keyword.
    v = np.array([[0, 0, 0], [0.01, 0, 0], [0, 0.01, 0], [0, 0, 0.01]], dtype=float)
    f = np.array([[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]])
    part = moldgate.Part(v, f)
    said = [w for w in part.warnings if "units" in w]
    assert said and all("--" not in w for w in said), part.warnings


def test_faces_without_vertices_say_there_are_none():
    with pytest.raises(moldgate.LoadError, match=r"^triangle 0 uses vertex 0, but there are no vertices$"):
        moldgate.Part(np.zeros((0, 3)), np.array([[0, 1, 2]]))


def test_a_study_stops_at_its_timeout_or_on_ctrl_c():
    import os
    import signal
    import threading
    import time

    # A study long enough to stop (the several-gate search on a fine grid of the cap).
    heavy = dict(gates=4, cell=0.3, suitability=True, objective="resistance")
    t = time.perf_counter()
    with pytest.raises(TimeoutError, match="took longer than its timeout of 0.2 s") as stop:
        moldgate.study(moldgate.sample("cover"), timeout=0.2, **heavy)
    stopped = time.perf_counter() - t
    assert stopped < 5, f"stopped after {stopped:.1f} s"
    # It names the stage it stopped in and what takes less time there, in keywords.
    said = str(stop.value)
    assert "stopped in the fill stage (a coarser cell, fewer gates or no suitability map take less time)" in said, said
    # Stopped in the fill stage, a study whose answer is the method's gate gives that gate.
    with pytest.raises(TimeoutError, match="the method's gate, found before the stop: ") as stop:
        moldgate.study(moldgate.sample("cover"), timeout=0.2, fill=True, cell=0.3, suitability=True)
    # Ctrl-C: the signal's KeyboardInterrupt, once the study has stopped.
    previous = signal.signal(signal.SIGINT, signal.default_int_handler)
    try:
        timer = threading.Timer(0.2, lambda: os.kill(os.getpid(), signal.SIGINT))
        timer.start()
        t = time.perf_counter()
        with pytest.raises(KeyboardInterrupt):
            moldgate.study(moldgate.sample("cover"), **heavy)
        assert time.perf_counter() - t < 5
    finally:
        timer.cancel()
        signal.signal(signal.SIGINT, previous)
    # A study inside its limit is the study without one; a bad limit is an options error.
    quick = moldgate.study(moldgate.sample("plate"), timeout=60)
    assert np.array_equal(quick.gate.point, moldgate.study(moldgate.sample("plate")).gate.point)
    for bad in (0, -1, float("nan"), "5", True, 1e9):
        with pytest.raises(moldgate.OptionsError, match="timeout"):
            moldgate.study(moldgate.sample("plate"), timeout=bad)


def test_arrays_too_large_for_memory_are_refused_before_any_copy():
    # numpy only pretends to hold these (broadcast): copying them would take the machine.
    huge = 10**12
    with pytest.raises(moldgate.LoadError, match=r"^faces: 1000000000000 rows need about .* GB to build the part, more than the .* GB of memory available$"):
        moldgate.Part(V, np.broadcast_to(F[:1].astype(np.int32), (huge, 3)))
    with pytest.raises(moldgate.LoadError, match=r"^vertices: 1000000000000 rows need about"):
        moldgate.Part(np.broadcast_to(V[:1], (huge, 3)), F)


def test_directions_as_numbers_and_other_pythonic_forms():
    plate = moldgate.sample("plate")
    along_z = moldgate.study(plate, demold="+z").gate.point
    for d in ([0, 0, 1], (0.0, 0.0, 1.0), np.array([0, 0, 1.0])):
        assert np.array_equal(moldgate.study(plate, demold=d).gate.point, along_z), d
    assert "aesthetic>" in repr(moldgate.study(moldgate.sample("cover"), aesthetic=True).gate)
    # A sample keeps its name in titles, as the command line's picture gives it.
    assert repr(moldgate.study(plate, demold="+z")).startswith("<moldgate.Study of sample 'plate': ")
    with pytest.raises(moldgate.OptionsError, match="got a flat list of 2 numbers"):
        moldgate.study(plate, gate_at=[1, 2])
    for bad in (-1, 0, float("nan"), "1"):
        with pytest.raises(moldgate.OptionsError, match="step_tolerance_mm must be a positive number"):
            moldgate.study(plate, step_tolerance_mm=bad)


def test_a_path_of_bytes_is_refused_by_its_type():
    with pytest.raises(TypeError, match=r"^path must be text or a path \(str or os.PathLike\), got bytes$"):
        moldgate.load(b"cover.stl")


def test_a_part_the_analysis_refuses_is_a_load_error_and_an_input_error(tmp_path):
    # A tetrahedron 2e8 mm long: too large for the automatic spacing. The part is at fault,
    # not an option: LoadError, and batch_row's input_error with the command line's exit 3.
    s = 2e8
    corners = [(0, 0, 0), (s, 0, 0), (0, s, 0), (0, 0, s)]
    facets = [(0, 2, 1), (0, 1, 3), (0, 3, 2), (1, 2, 3)]
    data = bytearray(b" " * 80) + struct.pack("<I", 4)
    for f in facets:
        data += struct.pack("<3f", 0, 0, 0)
        for v in f:
            data += struct.pack("<3f", *corners[v])
        data += b"\0\0"
    path = tmp_path / "huge.stl"
    path.write_bytes(bytes(data))
    with pytest.raises(moldgate.LoadError, match="automatic spacing"):
        moldgate.study(str(path))
    row = moldgate.batch_row(str(path))
    assert (row["status"], row["exit_code"]) == ("input_error", 3), row


def test_a_materials_file_or_batch_path_of_the_wrong_type_is_named():
    plate = moldgate.sample("plate")
    for bad in (b"x.toml", 3):
        with pytest.raises(moldgate.OptionsError, match=r"^materials_file must be text or a path \(str or os.PathLike\), got "):
            moldgate.study(plate, materials_file=bad)
        with pytest.raises(moldgate.OptionsError, match=r"^materials_file must be text or a path"):
            moldgate.check_options(materials_file=bad)
    with pytest.raises(TypeError, match=r"^path must be text or a path \(str or os.PathLike\), got bytes$"):
        moldgate.batch_row(b"cover.stl")
