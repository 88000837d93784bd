"""The real-object catalogue: readers on hand-made fixtures, the catalogue checker,
the split, and the committed catalogue itself.

No test needs the Debian packages or assimp: the readers run on tiny files written here, and
the one assimp test skips cleanly when ``assimp`` is not installed.
"""

import csv
import io
import re
import shutil
import struct
import zipfile
from collections import Counter
from pathlib import Path

import numpy as np
import pytest
import trimesh

from e2vlib import paper
from e2vlib.experiments.real_meshes.catalogue import RealMeshError
from e2vlib.experiments.real_meshes.mapping import read_mapping
from e2vlib.experiments.real_objects import catalogue as cat
from e2vlib.experiments.real_objects import readers
from e2vlib.experiments.real_objects.build import removed_summary
from e2vlib.experiments.real_objects.look import duplicates, pool, surface_grid, views

AC3D_PLANE = """AC3Db
MATERIAL "m" rgb 1 1 1 amb 1 1 1 emis 0 0 0 spec 0 0 0 shi 0 trans 0
OBJECT world
kids 2
OBJECT poly
name "body"
loc 0 0 0
numvert 4
0 0 0
2 0 0
2 1 0

0 1 0
numsurf 1
SURF 0x10
mat 0
refs 4
0 0 0
1 1 0
2 1 1
3 0 1
kids 0
OBJECT poly
name "shadow"
numvert 3
-5 -1 -5
5 -1 -5
0 -1 5
numsurf 1
SURF 0x10
mat 0
refs 3
0 0 0
1 0 0
2 0 0
kids 0
"""
"""A y-up AC3D file: a 2 x 1 quad (with a blank line inside its vertices, as some FlightGear
files have) and a large shadow triangle that the reader leaves out."""

TORCS_STRIP = """AC3Db
OBJECT world
kids 1
OBJECT poly
name "NONAME_s_20"
numvert 4
0 0 0 0 1 0
1 0 0 0 1 0
0 0 1 0 1 0
1 0 1 0 1 0
numsurf 1
SURF 0x34
mat 0
refs 4
0 0 0 0 0
1 1 0 1 0
2 0 1 0 1
3 1 1 1 1
kids 0
"""
"""A TORCS ``.acc`` body: one triangle strip (SURF type 4) of four vertices, with normals
after each vertex and extra texture coordinates after each reference."""


def md2_bytes(vertices: list[tuple[int, int, int]], triangles: list[tuple[int, int, int]],
              scale=(1.0, 1.0, 1.0), move=(0.0, 0.0, 0.0), magic=b"IDP2") -> bytes:
    """A minimal Quake 2 model: header, triangles, one frame (no skins, no texture
    coordinates, no GL commands)."""
    tris = b"".join(struct.pack("<6h", *t, 0, 0, 0) for t in triangles)
    frame = struct.pack("<6f16s", *scale, *move, b"frame0")
    frame += b"".join(bytes([x, y, z, 0]) for x, y, z in vertices)
    head_size = readers.MD2_HEADER.size
    o_tris = head_size
    o_frames = o_tris + len(tris)
    o_end = o_frames + len(frame)
    head = readers.MD2_HEADER.pack(magic, 8, 0, 0, len(frame), 0, len(vertices), 0,
                                   len(triangles), 0, 1, head_size, head_size, o_tris,
                                   o_frames, o_end, o_end)
    return head + tris + frame


TETRA = md2_bytes([(0, 0, 0), (40, 0, 0), (0, 20, 0), (0, 0, 10)],
                  [(0, 1, 2), (0, 1, 3), (0, 2, 3), (1, 2, 3)])
"""A tetrahedron 40 along x (Quake's forward), 20 along y, 10 up (z)."""


# --- readers -------------------------------------------------------------------------------


def test_ac3d_reader_drops_named_parts_and_reads_past_blank_lines(tmp_path):
    (tmp_path / "plane.ac").write_text(AC3D_PLANE)
    removed: list[str] = []
    mesh = readers.read_model(tmp_path, "plane.ac", removed)
    assert removed == ["shadow"]
    assert mesh.bounds.tolist() == [[0.0, 0.0, 0.0], [2.0, 1.0, 0.0]]
    framed = readers.load_model(tmp_path, "plane.ac", "")  # y up -> z up, longest side 1
    assert framed.extents.round(6).tolist() == [1.0, 0.0, 0.5]
    assert np.allclose(framed.bounds.mean(axis=0), 0)


def test_ac3d_reader_unrolls_torcs_triangle_strips(tmp_path):
    (tmp_path / "car.acc").write_text(TORCS_STRIP)
    mesh = readers.read_model(tmp_path, "car.acc")
    assert len(mesh.faces) == 2 and mesh.area == pytest.approx(1.0)


def test_ac3d_reader_names_the_file_for_bad_text(tmp_path):
    (tmp_path / "junk.ac").write_text("not an AC3D file\n")
    with pytest.raises(RealMeshError, match="junk.ac: not an AC3D file"):
        readers.read_model(tmp_path, "junk.ac")


def test_md2_reader_reads_the_first_frame_and_turns_it_to_our_frame(tmp_path):
    mesh = readers.md2_to_mesh(TETRA, "tetra.md2")
    assert mesh.extents.tolist() == [40.0, 20.0, 10.0]
    assert len(mesh.faces) == 4
    # Quake faces +x; the UFO:AI default turn z-90 puts the front to -y, longest side 1
    framed = readers.to_frame(mesh, ".md2", "z-90")
    assert framed.extents.round(6).tolist() == [0.5, 1.0, 0.25]


def test_md2_reader_scales_and_moves_vertices():
    data = md2_bytes([(0, 0, 0), (10, 0, 0), (0, 10, 0)], [(0, 1, 2)], scale=(0.5, 2, 1),
                     move=(1, 2, 3))
    assert readers.md2_to_mesh(data).bounds.tolist() == [[1.0, 2.0, 3.0], [6.0, 22.0, 3.0]]


@pytest.mark.parametrize("data, message", [
    (TETRA.replace(b"IDP2", b"IDP3", 1), "not an MD2 model"),
    (TETRA[:40], "shorter than an MD2 header"),
    (TETRA[:-8], "outside the"),
    (md2_bytes([(0, 0, 0), (1, 0, 0), (0, 1, 0)], [(0, 1, 7)]), "outside 0..2"),
])
def test_md2_reader_refuses_bad_files_naming_them(data, message):
    with pytest.raises(RealMeshError, match=f"gun.md2: .*{message}"):
        readers.md2_to_mesh(data, "gun.md2")


def test_models_inside_pk3_zips_are_read_by_member(tmp_path):
    with zipfile.ZipFile(tmp_path / "models.pk3", "w") as zf:
        zf.writestr("models/tetra.md2", TETRA)
        zf.writestr("models/box.obj", trimesh.exchange.obj.export_obj(trimesh.creation.box()))
    assert len(readers.read_model(tmp_path, "models.pk3::models/tetra.md2").faces) == 4
    assert len(readers.read_model(tmp_path, "models.pk3::models/box.obj").faces) == 12
    with pytest.raises(RealMeshError, match="models.pk3::models/gone.md2: cannot be read"):
        readers.read_model(tmp_path, "models.pk3::models/gone.md2")
    with pytest.raises(RealMeshError, match="no reader for '.blend'"):
        (tmp_path / "x.blend").write_bytes(b"BLENDER")
        readers.read_model(tmp_path, "x.blend")


def test_a_missing_package_names_the_download_step(tmp_path):
    with pytest.raises(RealMeshError, match="real_objects download"):
        readers.read_model(tmp_path, "usr/share/games/flightgear/plane.ac")


@pytest.mark.skipif(shutil.which("dpkg-deb") is None, reason="needs Debian's dpkg-deb")
def test_extract_unpacks_into_a_new_cache_folder(tmp_path):
    import subprocess

    from e2vlib.experiments.real_objects import sources

    tree = tmp_path / "tree"
    (tree / "DEBIAN").mkdir(parents=True)
    (tree / "DEBIAN" / "control").write_text(
        "Package: tiny-data\nVersion: 1\nArchitecture: all\nMaintainer: x <x@y.z>\n"
        "Description: a test package\n")
    (tree / "usr" / "share").mkdir(parents=True)
    (tree / "usr" / "share" / "model.ac").write_text("AC3Db\n")
    cache = tmp_path / "cache"  # a new machine: only debs/ exists, pkgs/ does not yet
    (cache / "debs").mkdir(parents=True)
    subprocess.run(["dpkg-deb", "--build", str(tree), str(cache / "debs" / "tiny-data_1_all.deb")],
                   check=True, capture_output=True)
    times = sources.extract(cache, ["tiny-data"])
    assert list(times) == ["tiny-data"]
    assert (cache / "pkgs" / "tiny-data" / "usr" / "share" / "model.ac").read_text() == "AC3Db\n"
    assert not (cache / "pkgs" / "tiny-data.part").exists()
    assert sources.extract(cache, ["tiny-data"]) == {}  # unpacked once


@pytest.mark.skipif(shutil.which("assimp") is None,
                    reason="assimp is not installed (apt-get install assimp-utils)")
def test_assimp_converts_through_obj(tmp_path):
    box = tmp_path / "box.obj"
    box.write_text(trimesh.exchange.obj.export_obj(trimesh.creation.box(extents=(3, 2, 1))))
    assert readers.assimp_to_mesh(box).extents.round(6).tolist() == [3.0, 2.0, 1.0]


def test_rotations_are_quarter_turns_applied_left_to_right():
    turn = readers.rotation_matrix("x90 z90")[:3, :3].round().astype(int)
    # y (up in a y-up file) goes to z; then x goes to y
    assert (turn @ [0, 1, 0]).tolist() == [0, 0, 1]
    assert (turn @ [1, 0, 0]).tolist() == [0, 1, 0]
    assert np.allclose(readers.rotation_matrix("none"), np.eye(4))
    with pytest.raises(ValueError, match="multiple of 90"):
        readers.rotation_matrix("z45")


def test_remove_parts_finds_ground_squares_and_light_cones():
    pole = trimesh.creation.box(extents=(0.05, 0.05, 1.0))
    square = trimesh.creation.box(extents=(1.5, 1.5, 0.005)).apply_translation((0, 0, -0.45))
    cone = trimesh.creation.cone(radius=0.6, height=0.9).apply_translation((0, 0, -0.5))
    kept, gone = readers.remove_parts(trimesh.util.concatenate([pole, square]), "ground")
    assert gone == [readers.GROUND_SQUARE] and kept.extents[0] == pytest.approx(0.05)
    kept, gone = readers.remove_parts(trimesh.util.concatenate([pole, cone]), "cones")
    assert gone == [readers.LIGHT_CONE] and kept.extents[0] == pytest.approx(0.05)
    kept, gone = readers.remove_parts(trimesh.util.concatenate([pole, cone]), "ground")
    assert gone == []  # a cone is not flat: no ground square to remove
    with pytest.raises(ValueError, match="unknown kinds"):
        readers.remove_parts(pole, "wheels")


def test_drop_part_keeps_the_nearest_level_of_detail():
    assert not readers.drop_part("LOD 0.000000/1000.000000")
    assert readers.drop_part("LOD 1000.000000/4000.000000")
    assert readers.drop_part("shadow") and not readers.drop_part("noshadow.Exhaust")
    assert not readers.drop_part("Silver_Shadow") and not readers.drop_part("Default LOD")
    names = ["shadow", "LOD 1000/4000", "lightcone", readers.GROUND_SQUARE, readers.LIGHT_CONE]
    assert removed_summary(names) == ("ground square (by shape) x1; light cone x1; "
                                      "light cone (by shape) x1; lod copy x1; shadow x1")


# --- looking: grids, pictures, duplicates --------------------------------------------------


def test_surface_grids_views_and_duplicates():
    box = trimesh.creation.box(extents=(1.0, 0.5, 0.25))
    occ = surface_grid(box, grid=16, samples=20_000)
    assert occ.shape == (16, 16, 16) and occ.any() and not occ[8, 8, 8]
    front, side, top = views(occ)
    assert (front < 255).any(axis=0).sum() == 16  # 1 m wide: every column
    assert (side < 255).any(axis=1).sum() in (4, 5)  # 0.25 m high: a quarter of the rows
    assert top.shape == (16, 16)
    other = surface_grid(box.copy().apply_scale(0.5), grid=16, samples=20_000)
    grids = {"a": pool(occ, 8), "b": pool(occ.copy(), 8), "c": pool(other, 8)}
    found = duplicates(grids, {"a": "car", "b": "car", "c": "car"})
    assert found == {"b": ("a", 1.0)}
    assert duplicates(grids, {"a": "car", "b": "bench", "c": "car"}) == {}  # per category


# --- the catalogue checker -----------------------------------------------------------------

ROW = {"id": "car_torcs_p406", "source": "torcs-data", "path": "cars/p406/p406.acc",
       "licence": "GPL-2.0-or-later", "category": "car", "rotation": "z90", "removed": "",
       "keep": "yes", "split": "train", "note": "looked: a saloon body"}


@pytest.mark.parametrize("change, message", [
    ({"category": "truck"}, "category 'truck' is not one of the paper's"),
    ({"id": "lamp_torcs_p406"}, "must start with its category"),
    ({"id": "car_P406"}, "is not a plain lower-case name"),
    ({"split": "dev"}, "needs a split"),
    ({"keep": "no"}, "a dropped row has no split"),
    ({"keep": "maybe"}, "keep must be yes or no"),
    ({"note": ""}, "note must start 'looked:'"),
    ({"note": "a saloon"}, "note must start 'looked:'"),
    ({"source": "torcs"}, "unknown source"),
    ({"licence": "GPL"}, "licence 'GPL' is not one of"),
    ({"rotation": "z45"}, "rotation 'z45'"),
    ({"path": " "}, "path is empty"),
])
def test_the_checker_names_the_file_line_and_problem(change, message):
    rows = [dict(ROW, id="car_torcs_other"), {**ROW, **change}]
    with pytest.raises(RealMeshError,
                       match=f"objects.csv: 1 bad row.*line 3: [^;]*{re.escape(message)}"):
        cat.check_catalogue(rows, "objects.csv")


def test_the_checker_catches_duplicate_ids_and_missing_columns():
    with pytest.raises(RealMeshError, match="line 3: duplicate id 'car_torcs_p406'"):
        cat.check_catalogue([ROW, dict(ROW)], "objects.csv")
    short = {k: v for k, v in ROW.items() if k != "split"}
    with pytest.raises(RealMeshError, match=r"line 2: missing columns \['split'\]"):
        cat.check_catalogue([short], "objects.csv")


def test_read_catalogue_refuses_bad_files_naming_them(tmp_path):
    good = tmp_path / "good.csv"
    cat.write_rows(good, [ROW, {**ROW, "id": "car_torcs_gone", "keep": "no", "split": ""}])
    assert [r.id for r in cat.read_catalogue(good)] == ["car_torcs_p406"]
    assert len(cat.read_catalogue(good, kept_only=False)) == 2
    wrong = tmp_path / "wrong.csv"
    wrong.write_text("id,category\ncar_x,car\n")
    with pytest.raises(RealMeshError, match="wrong.csv: columns must be"):
        cat.read_catalogue(wrong)
    latin = tmp_path / "latin.csv"
    latin.write_bytes(good.read_bytes().replace(b"saloon", b"sal\xf6on"))
    with pytest.raises(RealMeshError, match="latin.csv line 2: not UTF-8"):
        cat.read_catalogue(latin)
    with pytest.raises(FileNotFoundError, match="gone.csv not found"):
        cat.read_catalogue(tmp_path / "gone.csv")
    with pytest.raises(RealMeshError):  # write_rows checks before it writes
        cat.write_rows(tmp_path / "bad.csv", [{**ROW, "category": "truck"}])
    assert not (tmp_path / "bad.csv").exists()


# --- the split -----------------------------------------------------------------------------


def test_the_split_is_stratified_and_disjoint():
    ids = {c: [f"{c}_{i}" for i in range(n)] for c, n in
           [("car", 40), ("lamp", 20), ("telephone", 5), ("speaker", 2)]}
    splits = cat.assign_splits(ids)
    assert sorted(splits) == sorted(i for group in ids.values() for i in group)  # once each
    for c, group in ids.items():
        counts = Counter(splits[i] for i in group)
        if len(group) >= 3:
            assert set(counts) == set(cat.SPLITS), c
        for split, share in zip(cat.SPLITS, cat.SPLIT_FRACTIONS, strict=True):
            assert abs(counts[split] - share * len(group)) <= 1.5, (c, split)
    assert cat.assign_splits(ids) == splits  # fixed: the same ids give the same split


# --- the committed catalogue ---------------------------------------------------------------


def test_the_committed_catalogue_passes_its_checker():
    rows = cat.read_catalogue(kept_only=False)
    kept = [r for r in rows if r.keep]
    counts = Counter(r.category for r in kept)
    assert len(kept) >= 800 and len(counts) >= 12, counts
    assert set(counts) <= set(paper.CATEGORIES)
    # every kept object in exactly one split, each category in every split
    for category in counts:
        splits = Counter(r.split for r in kept if r.category == category)
        assert set(splits) == set(cat.SPLITS), (category, splits)
        assert splits["train"] >= splits["test"], category
    assert all(r.split == "" for r in rows if not r.keep)
    # the 241 reviewed Sweet Home 3D / crrcsim rows keep their ids
    assert {m.id for m in read_mapping()} <= {r.id for r in kept}
    # GPL and CC-BY-SA rows are never marked shareable
    assert all(r.licence not in cat.SHAREABLE for r in rows
               if r.licence.startswith(("GPL", "CC-BY-SA")))
    # one row per (source, path)
    assert len({(r.source, r.path) for r in rows}) == len(rows)


def test_the_committed_catalogue_is_written_as_its_writer_writes_it(tmp_path):
    rows = list(csv.DictReader(io.StringIO(cat.CATALOGUE_CSV.read_text(encoding="utf-8"))))
    again = tmp_path / "again.csv"
    cat.write_rows(again, rows)
    assert again.read_text(encoding="utf-8") == cat.CATALOGUE_CSV.read_text(encoding="utf-8")


def test_no_geometry_from_the_packages_is_tracked(tmp_path):
    """The catalogue's folder holds facts only: no mesh, grid or picture beside it."""
    folder = Path(cat.CATALOGUE_CSV).parent
    assert sorted(p.name for p in folder.iterdir()) == ["catalogue.csv"]


# --- the pipeline on a hand-made package tree ------------------------------------------------


def test_the_pipeline_runs_on_a_tiny_package_tree_and_reads_its_catalogue_back(tmp_path):
    """One TORCS body and one UFO:AI gun in fake unpacked packages: grids, a sheet, the typed
    review, the catalogue (with the 241 reviewed rows), and the same catalogue again from
    the written table alone."""
    from e2vlib.experiments.real_objects import build

    cache = tmp_path / "cache"
    car = cache / "pkgs/torcs-data/usr/share/games/torcs/cars/p406/p406.acc"
    car.parent.mkdir(parents=True)
    car.write_text(TORCS_STRIP.replace("0 0 1 0 1 0\n1 0 1", "0 0 3 0 1 0\n1 0 3"))
    pk3 = cache / "pkgs/ufoai-data/usr/share/games/ufoai/base/0models.pk3"
    pk3.parent.mkdir(parents=True)
    with zipfile.ZipFile(pk3, "w") as zf:
        zf.writestr("models/weapons/rifle/rifle.md2", TETRA)
    build.build_grids(cache)
    build.build_sheets(cache)
    assert (cache / "sheets" / "sheet_000.png").is_file()
    (cache / "review").mkdir()
    (cache / "review" / "s00.txt").write_text(
        "0.0|y||z180|a flat car body, turned to face -y\n0.1|y|||a tetrahedral gun\n")
    assert build.review_from_notes(cache) == 2
    out = tmp_path / "catalogue.csv"
    counts = build.write_catalogue(cache, out)
    rows = {r.id: r for r in cat.read_catalogue(out, kept_only=False)}
    assert rows["car_torcs_p406_p406"].rotation == "z180"
    assert rows["rifle_ufo_rifle_rifle"].licence == "GPL-2.0-or-later"
    assert rows["rifle_ufo_rifle_rifle"].note == "looked: a tetrahedral gun"
    assert counts["car"] == 1 + sum(m.category == "car" for m in read_mapping())
    # without review.csv the written catalogue is the review: the same table again
    (cache / "review.csv").unlink()
    review = build.review_from_catalogue(cache, out)
    assert {k: (r["rotation"], r["keep"]) for k, r in review.items()} == {
        "torcs__cars_p406_p406": ("z180", "yes"),
        "ufo__models_weapons_rifle_rifle": ("z-90", "yes")}
    again = tmp_path / "again.csv"
    build.write_catalogue(cache, again, reviewed=out)
    assert again.read_text() == out.read_text()
