"""STEP and IGES through gmsh: files the test writes itself with gmsh's OCC kernel."""

import builtins
import math

import numpy as np
import pytest

import moldgate

gmsh = pytest.importorskip("gmsh", reason='gmsh is not installed (pip install "moldgate[step]")')


def write_cad(path, build):
    """Builds a model with gmsh's OpenCASCADE kernel and writes it (STEP or IGES by name)."""
    gmsh.initialize(readConfigFiles=False)
    try:
        gmsh.option.setNumber("General.Terminal", 0)
        gmsh.model.add("part")
        build(gmsh.model.occ)
        gmsh.model.occ.synchronize()
        gmsh.write(str(path))
    finally:
        gmsh.finalize()
    return path


def box(occ):
    occ.addBox(0, 0, 0, 40, 30, 10)


def box_with_boss(occ):
    b = occ.addBox(0, 0, 0, 40, 30, 10)
    c = occ.addCylinder(10, 10, 10, 0, 0, 8, 4)
    occ.fuse([(3, b)], [(3, c)])


def cup(occ):
    outer = occ.addCylinder(0, 0, 0, 0, 0, 20, 15)
    inner = occ.addCylinder(0, 0, 2, 0, 0, 20, 13)
    occ.cut([(3, outer)], [(3, inner)])


@pytest.mark.parametrize("suffix", [".step", ".stp", ".iges", ".igs"])
def test_a_plain_box_gates_at_the_top_face_point_nearest_the_centre(tmp_path, suffix):
    path = write_cad(tmp_path / f"box{suffix}", box)
    part = moldgate.load(path)
    st = part.stats
    assert (st["open_edges"], st["non_manifold_edges"], st["bodies"]) == (0, 0, 1)
    assert st["bounds_min"] == pytest.approx([0, 0, 0], abs=1e-9)
    assert st["bounds_max"] == pytest.approx([40, 30, 10], abs=1e-9)
    assert st["area_mm2"] == pytest.approx(2 * (40 * 30 + 40 * 10 + 30 * 10), rel=1e-9)
    s = moldgate.study(part)
    g = s.gate.point
    # The surface centre of mass of a box is its centre; the nearest qualifying point is
    # on the top face, within one grid spacing of (20, 15).
    assert g[2] == pytest.approx(10.0)
    assert math.hypot(g[0] - 20, g[1] - 15) <= s.report["grid"]["spacing"]
    assert s.gate.normal == pytest.approx([0, 0, 1])
    assert s.report["input"]["path"] == str(path)
    # The report says the volume centroid is the box's centre too (outward triangles).
    assert s.report["centre_of_mass"]["volume"] == pytest.approx([20, 15, 5], abs=1e-6)


def test_a_box_with_a_boss_and_a_cup_load_closed(tmp_path):
    for name, build, volume in [
        ("boss", box_with_boss, 40 * 30 * 10 + math.pi * 16 * 8),
        ("cup", cup, math.pi * (15**2 * 20 - 13**2 * 18)),
    ]:
        part = moldgate.load(write_cad(tmp_path / f"{name}.step", build), step_tolerance_mm=1.0)
        st = part.stats
        assert (st["open_edges"], st["non_manifold_edges"], st["bodies"]) == (0, 0, 1), name
        # Outward triangles: the signed volume is the solid's, within the chord error.
        v, f = part.vertices, part.faces.astype(np.int64)
        signed = np.einsum("ij,ij->i", v[f[:, 0]], np.cross(v[f[:, 1]], v[f[:, 2]])).sum() / 6
        assert signed == pytest.approx(volume, rel=0.02), name
        s = moldgate.study(part, allow_no_gate=True)
        assert s.report["mesh"]["triangles"] == st["triangles"]
    # The cup opens to +z: its gate is on the bottom's outside when demoulded along -z.
    s = moldgate.study(tmp_path / "cup.step", demold="-z")
    assert s.gate.point[2] == pytest.approx(0.0, abs=1e-6)
    assert math.hypot(*s.gate.point[:2]) <= s.report["grid"]["spacing"]


def test_the_tolerance_sets_the_triangle_size(tmp_path):
    path = write_cad(tmp_path / "cup.step", cup)
    coarse = moldgate.load(path, step_tolerance_mm=4.0).stats["triangles"]
    fine = moldgate.load(path, step_tolerance_mm=1.0).stats["triangles"]
    assert fine > 4 * coarse
    with pytest.raises(moldgate.OptionsError, match="step_tolerance_mm must be a positive number"):
        moldgate.load(path, step_tolerance_mm=0)
    with pytest.raises(moldgate.OptionsError, match="STEP and IGES files only"):
        moldgate.load(tmp_path / "x.stl", step_tolerance_mm=1.0)


def test_a_step_file_gmsh_cannot_read_is_a_load_error_naming_it(tmp_path):
    bad = tmp_path / "broken.step"
    bad.write_text("ISO-10303-21;\nHEADER;\nthis is not a model\n")
    with pytest.raises(moldgate.LoadError, match=str(bad)):
        moldgate.load(bad)
    missing = tmp_path / "missing.stp"
    with pytest.raises(moldgate.LoadError, match=rf"{missing}: cannot open"):
        moldgate.load(missing)


def test_without_gmsh_the_error_names_the_extra(tmp_path, monkeypatch):
    path = tmp_path / "box.step"
    path.write_text("ISO-10303-21;\n")
    real_import = builtins.__import__

    def no_gmsh(name, *args, **kwargs):
        if name == "gmsh":
            raise ImportError("No module named 'gmsh'")
        return real_import(name, *args, **kwargs)

    monkeypatch.setattr(builtins, "__import__", no_gmsh)
    with pytest.raises(moldgate.LoadError, match=r'pip install "moldgate\[step\]"'):
        moldgate.load(path)


def test_step_files_load_from_worker_threads_as_from_the_main_one(tmp_path):
    from concurrent.futures import ThreadPoolExecutor

    path = write_cad(tmp_path / "box.step", box)
    serial = moldgate.study(path).report["gate"]
    # gmsh's SIGINT handler can be set from the main thread only: the worker threads'
    # sessions run without one, and leave no session behind.
    with ThreadPoolExecutor(3) as pool:
        gates = list(pool.map(lambda _: moldgate.study(path).report["gate"], range(3)))
    assert gates == [serial] * 3
    assert not gmsh.isInitialized()


@pytest.mark.skipif(not hasattr(__import__("os"), "mkfifo"), reason="no FIFOs on this system")
def test_a_fifo_named_like_a_step_file_is_refused_without_reading(tmp_path):
    import os

    fifo = tmp_path / "pipe.step"
    os.mkfifo(fifo)
    with pytest.raises(moldgate.LoadError, match="pipe.step: is a FIFO, not a mesh file"):
        moldgate.load(fifo)
