"""The Python API against the library and the command line."""

import inspect
import json
import threading

import numpy as np
import pytest

import moldgate
from conftest import run_cli, without_timings


def test_study_of_a_file_gives_the_cli_json(cover_stl, cli):
    s = moldgate.study(cover_stl, material="ABS", fill=True)
    r = run_cli(cli, "locate", cover_stl, "--material", "ABS", "--fill", "--json")
    assert without_timings(s.report) == without_timings(json.loads(r.stdout))
    assert without_timings(json.loads(s.to_json())) == without_timings(s.report)


def test_study_options_match_the_library_defaults():
    sig = inspect.signature(moldgate.study)
    library = moldgate.default_options()
    for name, default in library.items():
        assert name in sig.parameters, name
        value = sig.parameters[name].default
        value = list(value) if isinstance(value, tuple) else value
        assert value == default, (name, value, default)
    extra = {"part", "units", "materials_file", "step_tolerance_mm", "allow_no_gate", "timeout", "unknown"}
    assert set(sig.parameters) - set(library) == extra
    assert set(moldgate._OPTION_NAMES) == set(library)


def test_help_lists_the_options_with_defaults():
    import pydoc
    import re

    text = pydoc.render_doc(moldgate.study)
    params = inspect.signature(moldgate.study).parameters
    for name in moldgate.default_options():
        assert str(params[name]) in text, name  # "gate_radius: 'Optional[float]' = None"
        assert f"``{name}" in text, name  # described in the docstring
    assert "allow_no_gate" in text


def test_the_gate_and_its_fields():
    s = moldgate.study(moldgate.sample("cover"), wall_thickness=True)
    g = s.gate
    r = s.report
    assert isinstance(g.point, np.ndarray) and g.point.shape == (3,)
    assert g.point.tolist() == r["gate"]["point"]
    assert g.normal.tolist() == r["paper_gate"]["normal"]
    assert g.distance_mm == r["gate"]["distance_3d_mm"]
    assert g.wall_mm == r["paper_gate"]["thickness_mm"]
    assert g.radius_mm == r["options"]["gate_radius_mm"]
    assert (g.mode, g.strategy) == ("paper", "paper")
    assert len(s.gates) == 1
    q = s.qualifying_points
    assert q.shape == (r["counts"]["qualifying"], 3) and q.dtype == np.float64
    w = s.wall_thickness
    assert w.dtype == np.float32 and w.shape == (len(s.part.vertices),)
    assert np.nanmin(w) > 0
    assert s.fill_order is None


def test_the_report_advises_keywords_not_flags():
    # The cover with the automatic direction and the fill: its warnings advise
    # `--require-flat` on the command line, `require_flat=True` here.
    s = moldgate.study(moldgate.sample("cover"), demold="auto", fill=True)
    sentences = s.report["warnings"] + s.report["fill"]["warnings"]
    assert any("require_flat=True" in w for w in sentences), sentences
    assert not any("--" in w for w in sentences), sentences
    assert json.loads(s.to_json())["warnings"] == s.report["warnings"]
    page = s.html(picture=False)
    assert "require_flat=True" in page and "--require-flat" not in page


def test_only_the_grid_gate_has_the_paper_s_wall():
    # A layout's gates and the parting line's gate lie elsewhere than the grid gate: the
    # wall measured at the grid gate is not theirs.
    paper = moldgate.study(moldgate.sample("plate"))
    wall = paper.report["paper_gate"]["thickness_mm"]
    assert wall is not None and paper.gate.wall_mm == wall
    layout = moldgate.study(moldgate.sample("plate"), gates=2)
    for g in layout.gates:
        same = g.point.tolist() == layout.report["paper_gate"]["point"]
        assert g.wall_mm == (wall if same else None), (g.point, g.wall_mm)
    assert any(g.wall_mm is None for g in layout.gates)
    aesthetic = moldgate.study(moldgate.sample("plate"), aesthetic=True)
    assert aesthetic.gate.point.tolist() != aesthetic.report["paper_gate"]["point"]
    assert aesthetic.gate.wall_mm is None


def test_fill_order_and_several_gates():
    s = moldgate.study(moldgate.sample("plate"), gates=2)
    assert len(s.gates) == 2
    f = s.fill_order
    assert f.dtype == np.float32 and f.shape == (len(s.part.vertices),)
    assert 0.0 <= np.nanmin(f) < 0.5 and np.nanmax(f) == pytest.approx(1.0)
    assert s.flow_length is None
    # The pictured field is the one made per vertex: the flow length when asked for, its
    # largest value the layout's L_max (to the interpolation between cells and vertices).
    s = moldgate.study(moldgate.sample("plate"), gates=2, color_by="flow_length")
    length = s.flow_length
    assert length.dtype == np.float32 and length.shape == (len(s.part.vertices),)
    assert s.fill_time is None and s.fill_order is None
    l_max = s.report["fill"]["several"]["l_max_mm"]
    assert 0.0 <= np.nanmin(length) and np.nanmax(length) <= l_max * 1.001


def test_gates_placed_by_the_designer_are_judged_and_filled(cli):
    plate = moldgate.sample("plate")  # 100 x 60 x 3 with a hole of radius 8 at (20, 0)
    s = moldgate.study(plate, fill=True, gate_at=[(-30, 0, 5), np.array([20.0, 0.0, 3.0])])
    p = s.report["placed_gates"]
    first, second = p["gates"]
    assert first["asked"] == [-30.0, 0.0, 5.0]
    assert first["point"] == pytest.approx([-30.0, 0.0, 3.0])
    assert first["moved_mm"] == pytest.approx(2.0)
    assert first["qualifies"] and first["thickness_mm"] == pytest.approx(3.0)
    # The second is over the hole: it snaps to its rim and its disc runs off the part.
    assert not second["qualifies"] and second["failed_rule"] in ("circle_off_part", "not_seen_along_d")
    assert p["fill"]["l_max_mm"] > 0
    assert first["volume_share"] + second["volume_share"] == pytest.approx(1.0)
    # "x,y,z" text is the same point; the command line gives the same judgement.
    t = moldgate.study(plate, fill=True, gate_at=["-30,0,5", "20,0,3"])
    assert t.report["placed_gates"]["gates"] == p["gates"]
    if cli is not None:
        r = run_cli(cli, "locate", "--sample", "plate", "--fill", "--gate-at", "-30,0,5",
                    "--gate-at", "20,0,3", "--json")
        assert json.loads(r.stdout)["placed_gates"]["gates"] == p["gates"]


def test_suitability_map_as_numpy_arrays_agrees_with_the_report(cover_stl, cli):
    s = moldgate.study(cover_stl, material="ABS", suitability=True)
    m = s.suitability
    nodes = s.report["fill"]["suitability"]["nodes"]
    assert m.points.shape == (len(nodes), 3) and m.points.dtype == np.float64
    assert m.scores.shape == (len(nodes),) and m.exact.dtype == np.bool_
    assert np.array_equal(m.scores, [n["score"] for n in nodes])
    assert np.array_equal(m.points, [n["point"] for n in nodes])
    assert np.array_equal(m.exact, [n["kind"] == "exact" for n in nodes])
    # Every upper bound is at least its score; the best row has the least score.
    assert np.all(m.upper[~np.isnan(m.upper)] >= m.scores[~np.isnan(m.upper)])
    assert m.scores[m.best] == m.scores.min() and m.unit == "mm"
    # The nodes are qualifying points, and the map is the command line's.
    assert np.array_equal(s.qualifying_points[m.nodes], m.points)
    r = run_cli(cli, "locate", cover_stl, "--material", "ABS", "--suitability", "--json")
    assert without_timings(s.report) == without_timings(json.loads(r.stdout))
    assert moldgate.study(cover_stl, material="ABS").suitability is None


def test_pictures_and_files():
    s = moldgate.study(moldgate.sample("cap"))
    assert s.png().startswith(b"\x89PNG\r\n\x1a\n")
    assert s.glb()[:4] == b"glTF"
    page = s.html()
    assert page.lstrip().lower().startswith("<!doctype html") and "data:image/png;base64" in page
    assert "data:image/png" not in s.html(picture=False)


def test_part_arrays_are_views_of_the_part():
    p = moldgate.sample("cover")
    v, f = p.vertices, p.faces
    assert v.shape == (p.stats["vertices"], 3) and v.dtype == np.float64
    assert f.shape == (p.stats["triangles"], 3) and f.dtype == np.uint32
    assert np.shares_memory(v, p.vertices) and np.shares_memory(f, p.faces)
    assert not v.flags.writeable and not f.flags.writeable
    with pytest.raises(ValueError):
        v[0, 0] = 1.0
    again = moldgate.Part(v, f)
    assert np.array_equal(again.vertices, v) and np.array_equal(again.faces, f)
    assert again.stats["format"] == "arrays"
    assert again.stats["area_mm2"] == p.stats["area_mm2"]


def test_arrays_of_any_integer_and_float_dtype():
    p = moldgate.sample("plate")
    v, f = p.vertices, p.faces
    base = moldgate.study(p).report["gate"]
    small = np.uint16 if len(v) < 65536 else np.uint32
    for vd, fd in [(np.float32, np.int32), (np.float64, small), (np.float64, np.uint64)]:
        part = moldgate.Part(v.astype(vd), f.astype(fd))
        assert part.stats["triangles"] == p.stats["triangles"]
    ints = moldgate.Part(np.array([[0, 0, 0], [9, 0, 0], [0, 9, 0], [0, 0, 9]], dtype=np.int16),
                         np.array([[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]], dtype=np.int8))
    assert ints.vertices.dtype == np.float64 and ints.stats["open_edges"] == 0
    s = moldgate.study(moldgate.Part(v.tolist(), f.tolist()))
    assert s.report["gate"] == base
    cm = moldgate.Part(v / 10.0, f, units="cm")
    assert np.allclose(cm.vertices, v)


def test_trimesh_meshes_are_accepted():
    trimesh = pytest.importorskip("trimesh", reason="trimesh is not installed")
    box = trimesh.creation.box(extents=(40.0, 30.0, 10.0))
    s = moldgate.study(box)
    assert s.report["mesh"]["open_edges"] == 0
    same = moldgate.study(moldgate.Part.from_trimesh(box))
    assert same.report["gate"] == s.report["gate"]
    # The gate of a plain box: the top-face point nearest the centre of mass.
    assert s.gate.point[2] == pytest.approx(5.0)
    assert np.hypot(*s.gate.point[:2]) <= s.report["grid"]["spacing"]


def test_trimesh_arrays_are_read_without_a_copy():
    trimesh = pytest.importorskip("trimesh", reason="trimesh is not installed")
    import tracemalloc

    mesh = trimesh.creation.icosphere(subdivisions=6, radius=50.0)  # 81920 triangles
    assert mesh.vertices.dtype == np.float64 and mesh.faces.dtype == np.int64
    tracemalloc.start()
    part = moldgate.Part.from_trimesh(mesh)
    _, peak = tracemalloc.get_traced_memory()
    tracemalloc.stop()
    # numpy reports its allocations to tracemalloc: a copy of either array would show.
    assert peak < min(mesh.vertices.nbytes, mesh.faces.nbytes) / 4, peak
    assert part.stats["triangles"] == len(mesh.faces)


def test_materials_built_in_given_and_from_a_file(tmp_path):
    table = {m["name"]: m for m in moldgate.materials()}
    # The whole built-in library, the paper's Table 1 first (as `moldgate materials`).
    assert list(table)[:3] == ["PP", "ABS", "PC"] and "PA66-GF30" in table
    abs_ = table["ABS"]
    assert abs_["n"] == 0.2354 and abs_["gate_radius_mm"] > 0 and abs_["melt_velocity_m_s"] > 0
    part = moldgate.sample("cover")
    given = {k: abs_[k] for k in ("n", "t_melt", "t_wall", "gamma_opt", "mu_opt", "k")}
    s = moldgate.study(part, material=dict(given, name="MyABS"))
    assert s.report["options"]["gate_radius_mm"] == pytest.approx(abs_["gate_radius_mm"])
    assert s.report["gate"] == moldgate.study(part, material="ABS").report["gate"]
    f = tmp_path / "mine.toml"
    f.write_text("[Soft]\n" + "".join(f"{k} = {v}\n" for k, v in given.items()))
    listed = moldgate.materials(f)
    names = [m["name"] for m in listed]
    assert names == list(table) + ["Soft"]
    # Each entry is that of `moldgate materials --json`: aliases, description, sources.
    assert "HDPE" in table["PE-HD"]["aliases"] and table["PE-HD"]["typical"] is True
    assert table["PP"]["sources"]["n"] == "the paper, Table 1"
    assert table["PP"]["origin"] == "built-in" and table["PP"]["family"] == "polyolefin"
    soft = listed[-1]
    assert soft["origin"] == str(f) and soft["family"] == "user"
    assert soft["sources"]["k"] == f"the user file {f}"
    s = moldgate.study(part, material="soft", materials_file=f)
    assert s.report["material"]["name"] == "Soft"
    with pytest.raises(moldgate.OptionsError, match="material: missing field `t_melt`"):
        moldgate.study(part, material={"n": 0.3})
    bad = tmp_path / "bad.toml"
    bad.write_text("[X]\nn = 0.3\nt_melt = 'hot'\n")
    with pytest.raises(moldgate.OptionsError, match=r"bad\.toml: line 3"):
        moldgate.study(part, materials_file=bad)


def test_no_gate_raises_or_returns_a_study_without_gate():
    part = moldgate.sample("cap")
    with pytest.raises(moldgate.NoGateError, match="no node qualifies|qualif"):
        moldgate.study(part, gate_radius=30.0)
    s = moldgate.study(part, gate_radius=30.0, allow_no_gate=True)
    assert s.gate is None and s.gates == [] and s.report["no_gate_reason"]
    assert isinstance(moldgate.NoGateError("x"), ValueError)


def test_a_panic_is_an_internal_error_not_a_crash():
    with pytest.raises(moldgate.InternalError, match="a test panic"):
        moldgate._moldgate.panic_for_test()
    assert issubclass(moldgate.InternalError, RuntimeError)


def test_threads_study_parts_in_parallel_with_identical_reports(cover_stl):
    results = [None] * 4

    def work(i):
        results[i] = without_timings(moldgate.study(cover_stl, fill=True).report)

    threads = [threading.Thread(target=work, args=(i,)) for i in range(4)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    assert all(r is not None for r in results)
    assert all(r == results[0] for r in results)


def test_the_gil_is_released_during_a_study(cover_stl):
    # A Python thread keeps counting while another thread studies a part: with the GIL
    # held for the whole study it could not.
    counts = []
    done = threading.Event()

    def count():
        n = 0
        while not done.is_set():
            n += 1
        counts.append(n)

    t = threading.Thread(target=count)
    t.start()
    import time

    start = time.perf_counter()
    for _ in range(3):
        moldgate.study(cover_stl, fill=True)
    elapsed = time.perf_counter() - start
    done.set()
    t.join()
    # Held GIL: the counter would run only at switch intervals it never gets. A released
    # GIL lets it count freely; a rough floor of 10 000 increments per second is enough.
    assert counts[0] > 10_000 * elapsed, (counts, elapsed)


def test_batch_row_of_a_good_and_a_bad_file(cover_stl, tmp_path, cli):
    bad = tmp_path / "bad.stl"
    bad.write_bytes(b"solid x\n facet normal 0 0 1\n outer loop\n vertex 0 0 nan\n")
    rows = [moldgate.batch_row(p, material="ABS") for p in (cover_stl, bad)]
    summary = tmp_path / "s.jsonl"
    run_cli(cli, "locate", cover_stl, bad, "--material", "ABS", "--summary", summary, check=False)
    expected = [json.loads(line) for line in summary.read_text().splitlines()]
    for r, e in zip(rows, expected):
        r.pop("time_s"), e.pop("time_s")
        assert r == e
    assert rows[1]["status"] == "input_error" and "line 4" in rows[1]["error"]


def test_the_vertex_map_reads_a_field_on_the_callers_own_vertices():
    import numpy as np

    # A cube given with its vertices in reverse order, an unused vertex and a repeated one:
    # the part's vertices are welded and renumbered by first use.
    cube = moldgate.sample("plate")
    v = np.vstack([cube.vertices[::-1], [[500.0, 500.0, 500.0]], cube.vertices[:1]])
    n = len(cube.vertices)
    f = (n - 1) - cube.faces.astype(np.int64)
    part = moldgate.Part(v, f)
    m = part.vertex_map
    assert m.dtype == np.int64 and m.shape == (len(v),)
    assert m[n] == -1  # used by no triangle
    assert m[n + 1] == m[n - 1]  # the same position as the first vertex given reversed
    used = m >= 0
    # The same positions (but for the noise at zero, below 2^-40, welded as 0).
    assert np.abs(part.vertices[m[used]] - v[used]).max() < 1e-12
    assert sorted(set(m[used])) == list(range(len(part.vertices)))
    assert moldgate.sample("plate").vertex_map is None


def test_a_batch_row_past_its_timeout_says_so(cover_stl):
    import time

    heavy = dict(gates=4, cell=0.3, suitability=True, objective="resistance")
    t = time.perf_counter()
    row = moldgate.batch_row(cover_stl, timeout=0.2, **heavy)
    assert time.perf_counter() - t < 5
    assert row["status"] == "timeout" and row["exit_code"] == 6, row
    assert "stopped at its timeout of 0.2 s, in the fill stage" in row["error"], row
    # What takes less time, in the package's keywords.
    assert "(a coarser cell, fewer gates or no suitability map take less time)" in row["error"], row
    # A layout asked for and not found: no gate in the row.
    gate = lambda r: [r["gate_x_mm"], r["gate_y_mm"], r["gate_z_mm"]]
    assert gate(row) == [None, None, None], row
    # Stopped in the fill stage, a study whose answer is the method's gate keeps it.
    row = moldgate.batch_row(cover_stl, timeout=0.2, fill=True, cell=0.3, suitability=True)
    assert row["status"] == "timeout", row
    assert gate(row) == gate(moldgate.batch_row(cover_stl)), row
    assert "the method's gate, found before the stop" in row["error"], row
    # Within its limit, the row of no limit.
    quick = moldgate.batch_row(cover_stl, timeout=60)
    assert quick["status"] == "ok" and gate(quick) == gate(moldgate.batch_row(cover_stl))
    with pytest.raises(moldgate.OptionsError, match="timeout"):
        moldgate.batch_row(cover_stl, timeout=-1)
