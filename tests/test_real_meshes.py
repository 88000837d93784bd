"""Real meshes: the Sweet Home 3D catalogue reader, the reviewed mapping table, loading a
model in our frame, building the samples and scoring them (issue 25, "Real meshes").

Most tests use a small ``.sh3f``-like zip made here with known answers; the ones that need
Debian's ``sweethome3d-furniture`` skip, saying so, when it is not installed.
"""

import csv
import json
import zipfile
from pathlib import Path

import numpy as np
import pytest
import trimesh

from e2vlib import paper
from e2vlib.data import BuildConfig, E2VDataset, build_dataset
from e2vlib.experiments.real_meshes import (
    CRRCSIM,
    CRRCSIM_DIR,
    FURNITURE_DIR,
    LICENCES,
    MAPPING_CSV,
    MAPPING_FIELDS,
    POSES,
    RealMeshError,
    ac3d_to_mesh,
    build_real_dataset,
    check_mapping,
    crrcsim_entry,
    entry_licence,
    installed_libraries,
    licence_from_text,
    load_entry_mesh,
    parse_properties,
    read_catalogue,
    read_mapping,
    resolve,
)
from e2vlib.experiments.real_study import format_real_table, run_real_study, summarize_real
from e2vlib.metrics import interval95

INSTALLED = (FURNITURE_DIR.is_dir() and any(FURNITURE_DIR.glob("*.sh3f"))
             and CRRCSIM_DIR.is_dir())
needs_package = pytest.mark.skipif(
    not INSTALLED, reason="Debian's sweethome3d-furniture and crrcsim-data are not installed "
    "(apt-get install sweethome3d-furniture crrcsim-data)")

# An OBJ box of 2 (x) x 1 (y, up) x 4 (z, front) units in two parts: the box, and a small
# marker cube in front of it (+z, Sweet Home 3D's front) at mid height.
BOX_OBJ = """# two parts
o box
v -1 0 -2
v 1 0 -2
v 1 1 -2
v -1 1 -2
v -1 0 2
v 1 0 2
v 1 1 2
v -1 1 2
f 1 3 2
f 1 4 3
f 5 6 7
f 5 7 8
f 1 2 6
f 1 6 5
f 4 8 7
f 4 7 3
f 1 5 8
f 1 8 4
f 2 3 7
f 2 7 6
o marker
v -0.1 0.4 2.0
v 0.1 0.4 2.0
v 0.0 0.6 2.2
f 9 10 11
"""
# A flat phone: 1 (x) x 0.1 (y, up) x 2 (z, depth), one closed box.
FLAT_OBJ = trimesh.exchange.obj.export_obj(
    trimesh.creation.box(extents=(1.0, 0.1, 2.0)).apply_translation((0, 0.05, 0)))

PROPERTIES = r"""# PluginFurnitureCatalog.properties (test)
id=SweetHome3D#Test
name=Test library
license=Public domain

id#1=Test#box
name#1=Box table
category#1=Living room
creator#1=Someone
model#1=/test/box/box.obj
width#1=200
depth#1=400
height#1=100
multiPartModel#1=true

id#2=Test#phone
name#2=Caf\u00e9 phone, \
    flat
category#2 : Office
creator#2=Other
model#2=/test/phone/phone.obj
width#2=1
depth#2=2
height#2=0.1

id#3=Test#turned
name#3=Turned box
category#3=Office
creator#3=Other
model#3=/test/box/box.obj
modelRotation#3=1 0 0 0 0 1 0 -1 0
"""


def write_library(folder: Path, name: str = "BlendSwap-CC-0.sh3f",
                  extra: dict | None = None) -> Path:
    """A small .sh3f-like zip: the catalogue, two models, a per-model licence file."""
    folder.mkdir(parents=True, exist_ok=True)
    path = folder / name
    with zipfile.ZipFile(path, "w") as zf:
        zf.writestr("LICENSE.TXT", "This file is under the Creative Commons Zero license")
        zf.writestr("PluginFurnitureCatalog.properties", PROPERTIES.encode("latin-1"))
        zf.writestr("test/box/box.obj", BOX_OBJ)
        zf.writestr("test/phone/phone.obj", FLAT_OBJ)
        zf.writestr("test/phone/BLENDSWAP_LICENSE.txt",
                    "Thank you for downloading\nReleased under\nCreative Commons "
                    "Attribution 3.0\n")
        for member, text in (extra or {}).items():
            zf.writestr(member, text)
    return path


def mapping_row(**changes) -> dict:
    row = {"id": "table_bs0_box", "library": "BlendSwap-CC-0.sh3f",
           "entry_id": "Test#box", "name": "Box table", "creator": "Someone",
           "licence": "CC0-1.0", "licence_file": "LICENSE.TXT", "category": "table",
           "pose": "as_placed", "keep": "yes", "note": "looked: a box"}
    row.update(changes)
    return row


def write_mapping(path: Path, rows: list[dict]) -> Path:
    with open(path, "w", newline="") as f:
        writer = csv.DictWriter(f, fieldnames=MAPPING_FIELDS)
        writer.writeheader()
        writer.writerows(rows)
    return path


# --- the catalogue -------------------------------------------------------------------------


def test_properties_parser_follows_java_rules():
    text = ("# comment\n! also a comment\n  key1 = value one\nkey2:v2\nkey3 v3\n"
            "long=first \\\n    second\nesc\\ key=caf\\u00e9\\tx\nempty\n"
            "path=/a/b.obj\ndup=1\ndup=2\n")
    assert parse_properties(text) == {
        "key1": "value one", "key2": "v2", "key3": "v3", "long": "first second",
        "esc key": "café\tx", "empty": "", "path": "/a/b.obj", "dup": "2"}


def test_catalogue_of_a_small_library_has_the_known_entries(tmp_path):
    entries = read_catalogue(write_library(tmp_path))
    assert [e.number for e in entries] == [1, 2, 3]
    box, phone, turned = entries
    assert (box.entry_id, box.name, box.category, box.creator) == (
        "Test#box", "Box table", "Living room", "Someone")
    assert box.model == "test/box/box.obj"  # leading slash dropped
    assert box.size_cm == (200.0, 400.0, 100.0) and box.rotation is None
    assert box.licence == "CC0-1.0"  # the library's, by its file name
    assert phone.name == "Café phone, flat" and phone.category == "Office"
    assert turned.size_cm is None
    assert turned.rotation == (1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, -1.0, 0.0)


def test_bad_libraries_name_the_problem(tmp_path):
    with pytest.raises(FileNotFoundError, match="apt-get install sweethome3d-furniture"):
        read_catalogue(tmp_path / "missing.sh3f")
    with pytest.raises(FileNotFoundError, match="sweethome3d-furniture is not installed"):
        installed_libraries(tmp_path)
    (tmp_path / "junk.sh3f").write_bytes(b"not a zip")
    with pytest.raises(RealMeshError, match="not a readable .sh3f zip"):
        read_catalogue(tmp_path / "junk.sh3f")
    with zipfile.ZipFile(tmp_path / "empty.sh3f", "w") as zf:
        zf.writestr("x.txt", "x")
    with pytest.raises(RealMeshError, match="holds no PluginFurnitureCatalog.properties"):
        read_catalogue(tmp_path / "empty.sh3f")
    with zipfile.ZipFile(tmp_path / "nomodel.sh3f", "w") as zf:
        zf.writestr("PluginFurnitureCatalog.properties", "id#1=a\nname#1=A\n")
    with pytest.raises(RealMeshError, match="entry #1 has no model"):
        read_catalogue(tmp_path / "nomodel.sh3f")


# --- loading a model -----------------------------------------------------------------------


def test_a_model_loads_in_our_frame_scaled_to_the_catalogue(tmp_path):
    box, phone, turned = read_catalogue(write_library(tmp_path))
    mesh = load_entry_mesh(box, tmp_path)
    # catalogue width 200 (x), depth 400 (OBJ z -> our y), height 100 (OBJ y -> our z):
    # the OBJ's own 2 x 1 x 4.2 (with the marker) is scaled to it, then the longest side is 1
    assert np.allclose(mesh.extents, [0.5, 1.0, 0.25])
    assert np.allclose(mesh.bounds.mean(axis=0), 0.0)
    assert len(mesh.faces) == 13  # both parts: 12 box triangles and the marker
    # the marker stood in front (+z in the OBJ): in our frame the front is -y
    marker = mesh.vertices[np.argmin(mesh.vertices[:, 1])]
    assert marker[1] == pytest.approx(-0.5) and abs(marker[0]) < 1e-9
    raw = load_entry_mesh(box, tmp_path, normalize=False)
    assert np.allclose(raw.extents, [200.0, 400.0, 100.0])


def test_model_rotation_and_standing_a_phone_up(tmp_path):
    box, phone, turned = read_catalogue(write_library(tmp_path))
    # modelRotation (x, y, z) -> (x, z, -y) turns the box's 4-unit side upright
    assert np.allclose(load_entry_mesh(turned, tmp_path, normalize=False).extents,
                       [2.0, 1.0, 4.2])
    flat = load_entry_mesh(phone, tmp_path)
    assert np.allclose(flat.extents, [0.5, 1.0, 0.05])  # lying on its back
    up = load_entry_mesh(phone, tmp_path, pose="stood_up")
    assert np.allclose(up.extents, [0.5, 0.05, 1.0])  # standing, face to the front
    assert set(POSES) == {"as_placed", "stood_up"}
    with pytest.raises(ValueError, match="pose must be one of"):
        load_entry_mesh(phone, tmp_path, pose="sideways")


def test_a_missing_model_or_library_names_the_fix(tmp_path):
    box = read_catalogue(write_library(tmp_path))[0]
    with pytest.raises(FileNotFoundError, match="apt-get install sweethome3d-furniture"):
        load_entry_mesh(box, tmp_path / "elsewhere")
    lost = type(box)(**{**box.__dict__, "model": "test/none.obj"})
    with pytest.raises(RealMeshError, match="test/none.obj is missing from the library"):
        load_entry_mesh(lost, tmp_path)


AC3D = """AC3Db
MATERIAL "m" rgb 1 1 1  amb 0.2 0.2 0.2  emis 0 0 0  spec 0 0 0  shi 10  trans 0
OBJECT world
kids 2
OBJECT poly
name "quad"
loc 1 0 0
numvert 4
0 0 0
1 0 0
1 1 0
0 1 0
numsurf 2
SURF 0x10
mat 0
refs 4
0 0 0
1 1 0
2 1 1
3 0 1
SURF 0x2
mat 0
refs 2
0 0 0
1 0 0
kids 1
OBJECT poly
name "child"
loc 0 0 5
numvert 3
0 0 0
1 0 0
0 1 0
numsurf 1
SURF 0x30
mat 0
refs 3
0 0 0
1 0 0
2 0 0
kids 0
OBJECT poly
name "second"
data 5
hello
numvert 3
-1 -1 -1
0 0 -1
0 -1 -1
numsurf 1
SURF 0x0
mat 0
refs 3
0 0 0
1 0 0
2 0 0
kids 0
"""


def test_ac3d_objects_nest_their_locations_and_lines_are_left_out():
    mesh = ac3d_to_mesh(AC3D)
    assert len(mesh.faces) == 4  # the quad fanned into 2, the child's and second's 1 each
    assert np.allclose(mesh.bounds, [[-1, -1, -1], [2, 1, 5]])  # child at (1, 0, 0) + (0, 0, 5)
    assert np.allclose(sorted(mesh.area_faces), [0.5, 0.5, 0.5, 0.5])
    with pytest.raises(RealMeshError, match="not an AC3D file"):
        ac3d_to_mesh("OBJECT world\n")
    with pytest.raises(RealMeshError, match="line 10: expected 3 numbers"):
        ac3d_to_mesh(AC3D.replace("0 0 0\n1 0 0\n1 1 0", "0 0 0\n1 zero 0\n1 1 0", 1))
    with pytest.raises(RealMeshError, match="outside 0..3"):
        ac3d_to_mesh(AC3D.replace("3 0 1", "7 0 1"))


def test_a_crrcsim_entry_is_an_ac3d_file_with_the_package_licence(tmp_path):
    (tmp_path / "plane.ac").write_text(AC3D)
    entry = crrcsim_entry("plane.ac", tmp_path)
    assert (entry.library, entry.name, entry.licence) == (CRRCSIM, "plane", "GPL-2.0")
    assert entry_licence(entry)[0] == "GPL-2.0"
    mesh = load_entry_mesh(entry)
    assert np.allclose(mesh.extents, [0.5, 1.0, 1 / 3])  # AC3D y up: (3, 2, 6) -> x, z, y
    with pytest.raises(RealMeshError, match="plain .ac file name"):
        crrcsim_entry("../plane.ac", tmp_path)
    with pytest.raises(FileNotFoundError, match="apt-get install crrcsim-data"):
        load_entry_mesh(crrcsim_entry("plane.ac", tmp_path / "gone"))


# --- licences ------------------------------------------------------------------------------


def test_licences_come_from_the_model_folder_else_the_library(tmp_path):
    box, phone, _ = read_catalogue(write_library(tmp_path))
    assert entry_licence(box, tmp_path) == ("CC0-1.0", "LICENSE.TXT")
    assert entry_licence(phone, tmp_path) == ("CC-BY-3.0",
                                              "test/phone/BLENDSWAP_LICENSE.txt")
    html = ("<html><style>p {color: red}</style><p>This file has been released by X under "
            "the following license: Creative Commons Zero (Public Domain)</p></html>")
    assert licence_from_text(html) == "CC0-1.0"
    assert licence_from_text("Released under Creative Commons Attribution-NonCommercial "
                             "3.0") is None
    assert licence_from_text("Released under Creative Commons Attribution-ShareAlike "
                             "3.0") is None
    assert licence_from_text("Released under GPL") is None
    assert licence_from_text("no statement at all") is None


# --- the mapping table ---------------------------------------------------------------------


def test_mapping_rows_are_checked_each_with_its_line():
    good = check_mapping([mapping_row()])
    assert good[0].keep and good[0].category == "table"
    cases = [
        (mapping_row(category="bookshelf", id="bookshelf_x"), "is not one of the paper's"),
        (mapping_row(licence="MIT"), "licence 'MIT' is not one of"),
        (mapping_row(id="chair_bs0_box"), "must start with its category"),
        (mapping_row(id="Table/../x"), "not a plain lower-case name"),
        (mapping_row(pose="tilted"), "pose 'tilted'"),
        (mapping_row(keep="maybe"), "keep must be yes or no"),
        (mapping_row(note=" "), "note is empty"),
        (mapping_row(library="Other.sh3f"), "unknown library"),
        (mapping_row(licence_file=""), "licence_file is empty"),
        (mapping_row(licence="GPL-2.0"), "GPL-2.0 is allowed only for crrcsim-data rows"),
    ]
    for row, message in cases:
        with pytest.raises(RealMeshError) as err:
            check_mapping([row])
        assert "line 2: " in str(err.value) and message in str(err.value), message
    with pytest.raises(RealMeshError, match="line 3: duplicate id 'table_bs0_box'"):
        check_mapping([mapping_row(), mapping_row()])


def test_the_committed_catalogue_is_well_formed():
    rows = read_mapping(MAPPING_CSV, kept_only=False)
    kept = [r for r in rows if r.keep]
    assert len({r.id for r in rows}) == len(rows)
    assert all(r.category in paper.CATEGORIES for r in rows)
    assert all(r.licence in LICENCES for r in rows)
    assert all(r.library == CRRCSIM for r in rows if r.licence == "GPL-2.0")
    assert all(r.note.startswith("looked:") for r in kept)
    assert all(r.note.startswith("dropped:") for r in rows if not r.keep)
    assert len(kept) >= 100
    assert len({r.category for r in kept}) >= 9
    assert read_mapping(MAPPING_CSV) == kept


def test_a_mapping_file_with_other_columns_is_refused(tmp_path):
    path = tmp_path / "m.csv"
    with pytest.raises(FileNotFoundError, match="the reviewed one is"):
        read_mapping(path)
    path.write_text("id,category\nx,chair\n")
    with pytest.raises(RealMeshError, match="columns must be"):
        read_mapping(path)


@needs_package
def test_every_mapped_entry_is_installed_with_the_recorded_licence():
    rows = read_mapping(MAPPING_CSV, kept_only=False)
    pairs = resolve(rows)
    assert len(pairs) == len(rows)
    for mapped, entry in pairs:
        assert (mapped.name, mapped.creator) == (entry.name, entry.creator), mapped.id
        assert entry_licence(entry) == (mapped.licence, mapped.licence_file), mapped.id


@needs_package
def test_a_few_installed_models_load_normalized_and_upright():
    pairs = {m.id: (m, e) for m, e in resolve(read_mapping())}
    for sample_id in ("chair_bs0_plasticchair", "table_sc_round_table",
                      "telephone_bs0_iphone"):
        mapped, entry = pairs[sample_id]
        mesh = load_entry_mesh(entry, pose=mapped.pose)
        assert max(mesh.extents) == pytest.approx(1.0)
        assert np.allclose(mesh.bounds.mean(axis=0), 0.0, atol=1e-9)
        assert mesh.extents[2] > 0.5, sample_id  # these stand taller than half their size


# --- building and scoring ------------------------------------------------------------------


SETTINGS = {"resolution": 32, "frame_size": 16, "oversample": 2}


@pytest.fixture(scope="module")
def small_sets(tmp_path_factory):
    """A procedural train/val set of table and telephone, a real set of the test zip's two
    models at the same settings, and an untrained model for them."""
    from e2vlib.model import build_e2v, save_checkpoint

    base = tmp_path_factory.mktemp("real")
    train = base / "train"
    build_dataset(train, BuildConfig(categories=("table", "telephone"), per_category=10,
                                     **SETTINGS), progress=False)
    model = build_e2v("tiny", seed=0, input_shape=(100, 16, 16))
    save_checkpoint(base / "tiny.pt", model)
    library = base / "furniture"
    write_library(library)
    catalogue = write_mapping(base / "catalogue.csv", [
        mapping_row(),
        mapping_row(id="telephone_bs0_phone", entry_id="Test#phone",
                    name="Café phone, flat", creator="Other", licence="CC-BY-3.0",
                    licence_file="test/phone/BLENDSWAP_LICENSE.txt", category="telephone",
                    pose="stood_up"),
        mapping_row(id="table_bs0_turned", entry_id="Test#turned", keep="no",
                    note="dropped: a test row")])
    real = base / "real_set"
    config = BuildConfig(categories=paper.CATEGORIES, per_category=1, **SETTINGS)
    build_real_dataset(real, config, catalogue, library, progress=False)
    return {"train": train, "real": real, "catalogue": catalogue, "library": library,
            "checkpoint": base / "tiny.pt", "config": config}


def test_the_real_set_is_a_dataset_of_the_kept_rows(small_sets):
    real = small_sets["real"]
    test = E2VDataset(real, "test", verify=True)
    assert sorted(test.ids) == ["table_bs0_box", "telephone_bs0_phone"]
    item = test[test.ids.index("telephone_bs0_phone")]
    assert item["frames"].shape == (100, 16, 16) and item["frames"].sum() > 0
    voxels = item["voxels"].numpy().astype(bool)
    extent = [np.ptp(np.nonzero(voxels)[axis]) + 1 for axis in range(3)]
    assert extent[2] == 32 and extent[1] <= 3  # stood up: tall, thin front to back
    config = json.loads((real / "config.json").read_text())
    assert config["categories"] == ["table", "telephone"]
    assert config["source"]["install"] == "apt-get install sweethome3d-furniture"
    assert config["source"]["packages"] == ["sweethome3d-furniture"]
    before = {p.name: p.stat().st_mtime_ns for p in (real / "samples").iterdir()}
    build_real_dataset(real, small_sets["config"], small_sets["catalogue"],
                       small_sets["library"], progress=False)  # resumes: nothing rebuilt
    assert {p.name: p.stat().st_mtime_ns for p in (real / "samples").iterdir()} == before


def test_a_real_set_of_other_settings_is_refused(small_sets):
    other = BuildConfig(categories=paper.CATEGORIES, per_category=1, resolution=32,
                        frame_size=8, oversample=2)
    with pytest.raises(ValueError, match="was built with other settings"):
        build_real_dataset(small_sets["real"], other, small_sets["catalogue"],
                           small_sets["library"], progress=False)


def test_scoring_records_every_method_and_resumes(small_sets, tmp_path):
    kwargs = {"data": small_sets["real"], "train_data": small_sets["train"],
              "catalogue": small_sets["catalogue"], "n_points": 256, "progress": False}
    path = run_real_study(tmp_path, checkpoints={"tiny": str(small_sets["checkpoint"])},
                          **kwargs)
    results = json.loads(path.read_text())
    assert {r["id"] for r in results["runs"]} == {"table_bs0_box", "telephone_bs0_phone"}
    for run in results["runs"]:
        assert set(run["scores"]) == {"tiny", "visual_hull", "mean_shape", "category_oracle"}
        assert 0 <= run["scores"]["visual_hull"]["iou@0.3"] <= 1
        assert run["scores"]["tiny"]["val_threshold"] == results["checkpoints"]["tiny"][
            "val_threshold"]
    # the hull of a closed box, seen from every side with poses known, is near it (coarse
    # at 32 px) and well above the mean shape
    box = next(r for r in results["runs"] if r["id"] == "table_bs0_box")["scores"]
    assert box["visual_hull"]["iou@0.3"] > max(0.5, box["mean_shape"]["iou@0.3"] + 0.2)
    assert results["summary"]["visual_hull"]["overall"]["n"] == 2
    assert results["cpu"] and results["command"]
    # a second checkpoint is one more name: only it is scored, the rest is kept
    again = run_real_study(tmp_path, checkpoints={"best": str(small_sets["checkpoint"])},
                           **kwargs)
    rerun = json.loads(again.read_text())
    for old, new in zip(results["runs"], rerun["runs"], strict=True):
        assert new["scores"]["best"] == old["scores"]["tiny"]
        assert new["scores"]["visual_hull"] == old["scores"]["visual_hull"]
    with pytest.raises(ValueError, match="already scores a checkpoint named 'tiny'"):
        run_real_study(tmp_path, checkpoints={"tiny": "other.pt"}, **kwargs)
    assert "table" in format_real_table(again)


def test_summary_and_intervals_have_known_answers():
    assert interval95([1.0, 3.0]) == pytest.approx((2 - 12.7062 * 1 / 1, 2 + 12.7062))
    assert all(np.isnan(interval95([0.5])))
    runs = [{"category": "chair", "scores": {"a": {"iou@0.3": 0.2}}},
            {"category": "chair", "scores": {"a": {"iou@0.3": 0.4}}},
            {"category": "airplane", "scores": {"a": {"iou@0.3": 0.9}, "b": {"iou@0.3": 0.1}}}]
    summary = summarize_real(runs)
    assert list(summary["a"]["per_category"]) == ["airplane", "chair"]  # the paper's order
    assert summary["a"]["per_category"]["chair"]["mean"] == pytest.approx(0.3)
    assert summary["a"]["overall"]["n"] == 3 and summary["b"]["overall"]["n"] == 1
    # a category of one object has no interval: the table says so instead of "nan"
    only_a = [{**r, "scores": {"a": r["scores"]["a"]}} for r in runs]
    table = format_real_table({"runs": only_a})
    assert "nan" not in table
    assert "0.900 (1 object)" in table and "0.300 [-0.971, 1.571]" in table


def test_the_shipped_meshes_are_small_cc0_models_of_the_catalogue():
    from e2vlib.shapes import load_mesh

    folder = MAPPING_CSV.parent / "meshes"
    rows = {r.id: r for r in read_mapping()}
    files = sorted(folder.glob("*.ply"))
    readme = (folder / "README.md").read_text()
    assert 3 <= len(files) <= 5
    for path in files:
        row = rows[path.stem]
        assert row.licence == "CC0-1.0" and path.stat().st_size < 200_000
        assert path.name in readme and row.creator in readme and row.licence_file in readme
        mesh = load_mesh(path)
        assert max(mesh.extents) == pytest.approx(1.0)
        assert np.allclose(mesh.bounds.mean(axis=0), 0.0, atol=1e-6)


def test_building_without_the_package_names_the_install_step(tmp_path):
    config = BuildConfig(categories=paper.CATEGORIES, per_category=1, **SETTINGS)
    with pytest.raises(FileNotFoundError, match="apt-get install sweethome3d-furniture"):
        build_real_dataset(tmp_path / "out", config, MAPPING_CSV, tmp_path / "no_package",
                           progress=False)
    assert not (tmp_path / "out").exists()  # nothing written
