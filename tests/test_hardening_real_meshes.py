"""Hardening of the real-mesh inputs (issue 39): AC3D files whose counts would loop, ``.sh3f``
members that inflate past their bounds, resumed builds of a changed catalogue, real-mesh
flags that cannot apply, and the property that any file gives a mesh or a
:class:`RealMeshError` naming it.

Each test builds its own small files in ``tmp_path`` with known answers (Debian's packages
are not needed).
"""

from __future__ import annotations

import contextlib
import json
import os
import shutil
import signal
import subprocess
import sys
import textwrap
import zipfile
from pathlib import Path

import numpy as np
import pytest
import trimesh
from hypothesis import given
from hypothesis import strategies as st

from e2vlib import paper
from e2vlib.data import BuildConfig, E2VDataset, build_dataset
from e2vlib.experiments.real_meshes import (
    RealMeshError,
    ac3d_to_mesh,
    build_real_dataset,
    crrcsim_entry,
    entry_licence,
    load_entry_mesh,
    read_catalogue,
    read_mapping,
)
from e2vlib.experiments.real_study import (
    format_real_table,
    run_real_study,
    summarize_real,
)
from e2vlib.experiments.real_study import (
    main as real_study_main,
)
from tests.test_real_meshes import AC3D, mapping_row, write_library, write_mapping

REPO = Path(__file__).resolve().parents[1]
SETTINGS = {"resolution": 32, "frame_size": 16, "oversample": 2}


@contextlib.contextmanager
def no_hang(seconds: int = 20):
    """Turn a parser that never returns into a failure (SIGALRM), not a stuck test run."""
    def stop(signum, frame):
        raise TimeoutError(f"still running after {seconds} s: the parser loops")

    previous = signal.signal(signal.SIGALRM, stop)
    signal.alarm(seconds)
    try:
        yield
    finally:
        signal.alarm(0)
        signal.signal(signal.SIGALRM, previous)


def ac3d_lines() -> list[str]:
    return AC3D.splitlines()


def replaced(old: str, new: str, count: int = 1) -> str:
    assert old in AC3D
    return AC3D.replace(old, new, count)


# --- Bad: loops -----------------------------------------------------------------------------

LOOPING_COUNTS = {
    "negative numvert": (replaced("numvert 4", "numvert -3"), "line 8: numvert needs"),
    "negative refs": (replaced("refs 4", "refs -5"), "line 16: refs needs"),
    "oversized numvert": (replaced("numvert 4", "numvert 4000000000"),
                          "line 8: numvert 4000000000 is more than"),
    "oversized numsurf": (replaced("numsurf 2", "numsurf 99"), "line 13: numsurf 99 is more"),
    "oversized refs": (replaced("refs 4", "refs 70"), "line 16: refs 70 is more"),
    "negative kids": (replaced("kids 2", "kids -1"), "line 4: kids needs"),
    "oversized kids": (replaced("kids 2", "kids 500"), "line 4: kids 500 is more"),
}


@pytest.mark.parametrize("case", sorted(LOOPING_COUNTS))
def test_ac3d_counts_are_checked_before_the_cursor_moves(case):
    text, message = LOOPING_COUNTS[case]
    with no_hang(), pytest.raises(RealMeshError, match=f"plane.ac {message}"):
        ac3d_to_mesh(text, "plane.ac")


def _run_killing_the_group(command: list[str], timeout: int, **kwargs):
    """subprocess.run whose timeout also ends the workers the command spawned."""
    process = subprocess.Popen(command, start_new_session=True, stdout=subprocess.PIPE,
                               stderr=subprocess.PIPE, text=True, **kwargs)
    try:
        out, err = process.communicate(timeout=timeout)
    except subprocess.TimeoutExpired:
        os.killpg(process.pid, signal.SIGKILL)
        process.communicate()
        pytest.fail(f"{' '.join(command[:3])} still running after {timeout} s (it loops)")
    return process.returncode, out, err


# make-data reads the libraries and crrcsim-data where Debian installs them; this script
# points both at the test's folders, then runs the command line as `python -m e2vlib` would
MAKE_DATA = textwrap.dedent("""
    import sys
    from pathlib import Path
    from e2vlib.experiments.real_meshes import build, mapping
    library, crrcsim = Path(sys.argv[1]), Path(sys.argv[2])
    build.CRRCSIM_DIR = crrcsim
    mapping.resolve.__defaults__ = (library, crrcsim)
    defaults = list(build.build_real_dataset.__defaults__)
    defaults[1] = library
    build.build_real_dataset.__defaults__ = tuple(defaults)
    from e2vlib.__main__ import main
    sys.exit(main(sys.argv[3:]))
""")


@pytest.mark.slow
def test_make_data_with_two_workers_refuses_a_looping_aircraft(tmp_path):
    library, crrcsim = tmp_path / "furniture", tmp_path / "crrcsim"
    write_library(library)
    crrcsim.mkdir()
    for name in ("plane.ac", "glider.ac"):
        (crrcsim / name).write_text(replaced("numvert 4", "numvert -3"))
    rows = [mapping_row(id=f"airplane_crrc_{n}", library="crrcsim-data", entry_id=f"{n}.ac",
                        licence="GPL-2.0", category="airplane") for n in ("plane", "glider")]
    catalogue = write_mapping(tmp_path / "catalogue.csv", rows)
    status, _, err = _run_killing_the_group(
        [sys.executable, "-c", MAKE_DATA, str(library), str(crrcsim), "make-data",
         "--out", str(tmp_path / "out"), "--real-meshes", str(catalogue), "--resolution",
         "32", "--frame-size", "16", "--oversample", "2", "--workers", "2"],
        timeout=90, cwd=REPO)
    last = err.strip().splitlines()[-1]  # after the progress bar's lines
    assert status == 1 and last.startswith("error: "), err
    assert "ac line 8: numvert needs one whole number >= 0" in last and "Traceback" not in err


# --- Bad: memory ----------------------------------------------------------------------------


def _lie_about_size(path: Path, member: str, declared: int) -> None:
    """Rewrite the size the zip declares for ``member`` (both headers), keeping its data."""
    data = bytearray(path.read_bytes())
    name = member.encode()
    for signature, size_at in ((b"PK\x03\x04", 22), (b"PK\x01\x02", 24)):
        start = 0
        while (at := data.find(signature, start)) >= 0:
            name_at = at + (30 if signature == b"PK\x03\x04" else 46)
            if data[name_at:name_at + len(name)] == name:
                data[at + size_at:at + size_at + 4] = declared.to_bytes(4, "little")
            start = at + 4
    path.write_bytes(bytes(data))


CATALOGUE = "PluginFurnitureCatalog.properties"


def deflated_library(folder: Path, members: dict[str, bytes]) -> Path:
    """The test library (:func:`write_library`), deflated, with ``members`` replaced."""
    path = write_library(folder)
    with zipfile.ZipFile(path) as zf:
        data = {n: zf.read(n) for n in zf.namelist()}
    data.update(members)
    with zipfile.ZipFile(path, "w", zipfile.ZIP_DEFLATED) as zf:
        for name, value in data.items():
            zf.writestr(name, value)
    return path


def test_a_catalogue_over_its_bound_is_refused_before_it_is_read(tmp_path):
    # one value of 17 MiB (it deflates to a few KB): the catalogue is refused by its size
    big = b"id#1=Test#box\nname#1=" + b"x" * (17 << 20) + b"\nmodel#1=/test/box/box.obj\n"
    path = deflated_library(tmp_path, {CATALOGUE: big})
    with pytest.raises(RealMeshError, match=r"PluginFurnitureCatalog.properties is 1782\d+ "
                       r"bytes, more than the bound of 16777216 bytes"):
        read_catalogue(path)


def test_members_inflating_past_their_declared_size_are_stopped(tmp_path):
    # the catalogue declares 200 bytes and inflates to 40 MB; the OBJ the same
    path = deflated_library(tmp_path, {CATALOGUE: b"id#1=Test#box\nname#1=Box\nmodel#1=/test/"
                                       b"box/box.obj\n#" + b"0" * (40 << 20) + b"\n"})
    _lie_about_size(path, "PluginFurnitureCatalog.properties", 200)
    with pytest.raises(RealMeshError, match="PluginFurnitureCatalog.properties cannot be "
                       "read .BadZipFile"):
        read_catalogue(path)
    path = deflated_library(tmp_path / "obj", {"test/box/box.obj": b"#" * (40 << 20)})
    box = read_catalogue(path)[0]
    _lie_about_size(path, "test/box/box.obj", 100)
    with pytest.raises(RealMeshError, match=r"entry #1 \(Box table\): test/box/box.obj "
                       "cannot be read"):
        load_entry_mesh(box, tmp_path / "obj")


def test_a_licence_file_over_its_bound_is_refused(tmp_path):
    path = deflated_library(tmp_path, {"test/phone/BLENDSWAP_LICENSE.txt":
                                       b"Released under CC0 " * 60000})
    phone = read_catalogue(path)[1]
    with pytest.raises(RealMeshError, match="BLENDSWAP_LICENSE.txt is 1140000 bytes, more "
                       "than the bound of 1048576"):
        entry_licence(phone, tmp_path)


# --- Bad: silent wrong answers ---------------------------------------------------------------


@pytest.fixture(scope="module")
def real_set(tmp_path_factory):
    """A procedural train/val set of table and telephone, an untrained model, and a real set
    of the test zip's box and phone (the phone lying as placed)."""
    from e2vlib.model import build_e2v, save_checkpoint

    base = tmp_path_factory.mktemp("hardening_real")
    build_dataset(base / "train", BuildConfig(categories=("table", "telephone"),
                                              per_category=10, **SETTINGS), progress=False)
    save_checkpoint(base / "tiny.pt", build_e2v("tiny", seed=0, input_shape=(100, 16, 16)))
    write_library(base / "furniture")
    rows = [mapping_row(), mapping_row(
        id="telephone_bs0_phone", entry_id="Test#phone", name="Café phone, flat",
        creator="Other", licence="CC-BY-3.0", licence_file="test/phone/BLENDSWAP_LICENSE.txt",
        category="telephone")]
    config = BuildConfig(categories=paper.CATEGORIES, per_category=1, **SETTINGS)
    build_real_dataset(base / "real", config, write_mapping(base / "catalogue.csv", rows),
                       base / "furniture", progress=False)
    return {"base": base, "rows": rows, "config": config}


def _copy_set(real_set, tmp_path: Path) -> Path:
    out = tmp_path / "real"
    shutil.copytree(real_set["base"] / "real", out)
    return out


def _phone_extent(root: Path) -> list[int]:
    test = E2VDataset(root, "test", verify=True)  # also checks each sample's sha256
    voxels = test[test.ids.index("telephone_bs0_phone")]["voxels"].numpy().astype(bool)
    return [int(np.ptp(np.nonzero(voxels)[axis])) + 1 for axis in range(3)]


@pytest.mark.slow  # builds a real set first (7 s); CI runs it (make test-all)
def test_a_resumed_build_remakes_the_sample_of_a_row_whose_pose_changed(real_set, tmp_path):
    root = _copy_set(real_set, tmp_path)
    assert _phone_extent(root)[2] <= 3  # lying flat, as placed
    box_before = (root / "samples" / "table_bs0_box.npz").read_bytes()
    rows = [real_set["rows"][0], {**real_set["rows"][1], "pose": "stood_up"}]
    build_real_dataset(root, real_set["config"], write_mapping(tmp_path / "c.csv", rows),
                       real_set["base"] / "furniture", progress=False)
    assert _phone_extent(root)[2] == 32  # made again: standing up
    assert (root / "samples" / "table_bs0_box.npz").read_bytes() == box_before  # kept
    source = json.loads((root / "config.json").read_text())["source"]
    assert source["rows"]["telephone_bs0_phone"].endswith(" stood_up")


@pytest.mark.slow  # builds a real set first (7 s); CI runs it (make test-all)
def test_grey_video_with_real_meshes_is_refused(real_set, tmp_path, capsys):
    from e2vlib.__main__ import main

    grey = BuildConfig(categories=paper.CATEGORIES, per_category=1, grey_video=True,
                       **SETTINGS)
    with pytest.raises(ValueError, match="stores no grey video"):
        build_real_dataset(tmp_path / "grey", grey, real_set["base"] / "catalogue.csv",
                           real_set["base"] / "furniture", progress=False)
    assert not (tmp_path / "grey").exists()
    status = main(["make-data", "--out", str(tmp_path / "cli"), "--real-meshes",
                   str(real_set["base"] / "catalogue.csv"), "--grey-video"])
    assert status == 2 and "--grey-video (the real-mesh set stores no grey video)" in (
        capsys.readouterr().err)
    assert not (tmp_path / "cli").exists()


@pytest.mark.slow  # builds a real set first (7 s); CI runs it (make test-all)
def test_real_study_forgets_an_object_the_catalogue_dropped(real_set, tmp_path):
    base = real_set["base"]
    root = _copy_set(real_set, tmp_path)
    kwargs = {"data": root, "train_data": base / "train", "n_points": 128, "progress": False,
              "checkpoints": {"tiny": str(base / "tiny.pt")}}
    run_real_study(tmp_path / "out", catalogue=base / "catalogue.csv", **kwargs)
    rows = [real_set["rows"][0], {**real_set["rows"][1], "keep": "no",
                                  "note": "dropped: a test row"}]
    catalogue = write_mapping(tmp_path / "c.csv", rows)
    build_real_dataset(root, real_set["config"], catalogue, base / "furniture",
                       progress=False)
    path = run_real_study(tmp_path / "out", catalogue=catalogue, **kwargs)
    results = json.loads(path.read_text())
    assert [r["id"] for r in results["runs"]] == ["table_bs0_box"]
    assert results["summary"]["tiny"]["overall"]["n"] == 1
    assert "telephone" not in format_real_table(path)
    assert [r["id"] for r in results["dropped_runs"]] == ["telephone_bs0_phone"]  # kept aside


def test_duplicated_and_unknown_records_are_not_counted():
    runs = [{"id": "chair_a", "category": "chair", "scores": {"m": {"iou@0.3": 0.2}}},
            {"id": "chair_a", "category": "chair", "scores": {"m": {"iou@0.3": 0.2}}},
            {"id": "chair_b", "category": "chair", "scores": {"m": {"iou@0.3": 0.4}}},
            {"id": "shelf_c", "category": "bookshelf", "scores": {"m": {"iou@0.3": 1.0}}}]
    summary = summarize_real(runs)["m"]
    assert summary["overall"]["n"] == 2 and summary["overall"]["mean"] == pytest.approx(0.3)
    assert list(summary["per_category"]) == ["chair"]
    assert summarize_real(runs, ids=["chair_b"])["m"]["overall"]["n"] == 1
    table = format_real_table({"runs": runs})
    assert "left out: chair_a (a second record), shelf_c (category 'bookshelf'" in table


# --- Poor ------------------------------------------------------------------------------------

MALFORMED = {
    "numvert at the end": ("\n".join(ac3d_lines()[:8]), "line 8: numvert 4 is more than "
                           "the 0 the 0 lines left can hold"),
    "refs at the end": ("\n".join(ac3d_lines()[:12] + ["numsurf 1", "SURF 0", "mat 0",
                                                        "refs 4"]),
                        "line 16: refs 4 is more than the 0"),
    "no refs at the end": ("\n".join(ac3d_lines()[:12] + ["numsurf 1", "SURF 0x10", "mat 0"]),
                           "the file ends where refs should be .after line 15."),
    "a word for refs": (replaced("refs 4", "refs four"), "line 16: refs needs"),
    "a fraction for numvert": (replaced("numvert 4", "numvert 2.5"), "line 8: numvert needs"),
    "a word for a vertex reference": (replaced("2 1 1", "two 1 1"),
                                      "line 19: a vertex reference must be"),
    "no flags on SURF": (replaced("SURF 0x10", "SURF"), "line 14: bad SURF flags"),
    "a second numvert": (replaced("kids 1\n", "numvert 1\n0 0 0\nkids 1\n"),
                         "line 26: a second numvert"),
    "deep kids": ("AC3Db\n" + "OBJECT group\nkids 1\n" * 3000 + "OBJECT poly\nkids 0\n",
                  "line 130: objects nest deeper than MAX_AC3D_DEPTH"),
    "huge coordinates": (replaced("0 1 0\nnumsurf 2", "0 1e300 0\nnumsurf 2"),
                         "reaches 1e\\+300 units from the origin"),
}


@pytest.mark.parametrize("case", sorted(MALFORMED))
def test_malformed_ac3d_files_are_refused_naming_the_file_and_line(case):
    text, message = MALFORMED[case]
    with no_hang(), pytest.raises(RealMeshError, match=f"plane.ac.*{message}"):
        ac3d_to_mesh(text, "plane.ac")


def _patch_member(path: Path, member: str, offset: int, value: bytes) -> None:
    """Overwrite bytes at ``offset`` of ``member``'s central and local headers."""
    data = bytearray(path.read_bytes())
    for signature, name_at in ((b"PK\x03\x04", 30), (b"PK\x01\x02", 46)):
        start = 0
        while (at := data.find(signature, start)) >= 0:
            if data[at + name_at:at + name_at + len(member)] == member.encode():
                shift = offset + (2 if signature == b"PK\x01\x02" else 0)
                data[at + shift:at + shift + len(value)] = value
            start = at + 4
    path.write_bytes(bytes(data))


def test_damaged_zip_members_are_real_mesh_errors_naming_the_entry(tmp_path):
    cases = {"crc": (14, b"\0\0\0\0", "cannot be read .BadZipFile: Bad CRC"),
             "method": (8, (99).to_bytes(2, "little"), "is compressed by zip method 99"),
             "encrypted": (6, (1).to_bytes(2, "little"), "cannot be read .RuntimeError")}
    for case, (offset, value, message) in cases.items():
        folder = tmp_path / case
        box = read_catalogue(write_library(folder))[0]
        _patch_member(folder / "BlendSwap-CC-0.sh3f", "test/box/box.obj", offset, value)
        with pytest.raises(RealMeshError, match=rf"entry #1 \(Box table\): test/box/box.obj "
                           f"{message}"):
            load_entry_mesh(box, folder)
    (tmp_path / "folder.sh3f").mkdir()
    with pytest.raises(RealMeshError, match="folder.sh3f is not a regular file"):
        read_catalogue(tmp_path / "folder.sh3f")


def test_catalogue_tables_in_other_encodings(tmp_path):
    path = write_mapping(tmp_path / "c.csv", [mapping_row()])
    bom = tmp_path / "bom.csv"
    bom.write_bytes(b"\xef\xbb\xbf" + path.read_bytes())
    assert [m.id for m in read_mapping(bom)] == ["table_bs0_box"]  # a BOM is accepted
    latin = tmp_path / "latin.csv"
    latin.write_bytes(path.read_bytes() + "table_bs0_b,BlendSwap-CC-0.sh3f,Test#b,Café,X,"
                      "CC0-1.0,LICENSE.TXT,table,as_placed,yes,looked\n".encode("latin-1"))
    with pytest.raises(RealMeshError, match="latin.csv line 3: not UTF-8 text"):
        read_mapping(latin)
    binary = tmp_path / "binary.csv"
    binary.write_bytes(b"id,library\n\x00\xff\xfe\x81" * 3)
    with pytest.raises(RealMeshError, match="binary.csv line 2: not UTF-8 text"):
        read_mapping(binary)


def test_an_empty_catalogue_builds_nothing(tmp_path):
    write_library(tmp_path / "furniture")
    config = BuildConfig(categories=paper.CATEGORIES, per_category=1, **SETTINGS)
    for rows in ([], [mapping_row(keep="no", note="dropped: all")]):
        catalogue = write_mapping(tmp_path / "c.csv", rows)
        with pytest.raises(RealMeshError, match="c.csv keeps no row .keep=yes."):
            build_real_dataset(tmp_path / "out", config, catalogue, tmp_path / "furniture",
                               progress=False)
        assert not (tmp_path / "out").exists()


REFUSED_FLAGS = {
    "--categories": (["--categories", "chair"], "the catalogue sets the categories"),
    "--shard": (["--shard", "1/2"], "the real-mesh set is built whole"),
    "--splits": (["--splits", "test"], "every real object is a test sample"),
    "--per-category": (["--per-category", "4"], "the catalogue sets the objects"),
    "--raw-events-per-category": (["--raw-events-per-category", "3"],
                                  "the real-mesh set keeps no raw events"),
}


@pytest.mark.parametrize("flag", sorted(REFUSED_FLAGS))
def test_flags_a_real_mesh_build_cannot_honour_are_refused(flag, tmp_path, capsys):
    from e2vlib.__main__ import main

    extra, reason = REFUSED_FLAGS[flag]
    status = main(["make-data", "--out", str(tmp_path / "out"), "--real-meshes",
                   str(REPO / "data_small" / "real" / "catalogue.csv"), *extra])
    err = capsys.readouterr().err
    assert status == 2 and f"{flag} ({reason}" in err, err
    assert not (tmp_path / "out").exists()


def test_the_lab_commands_fail_in_one_line(tmp_path, capsys):
    from e2vlib.experiments.shipping import main as shipping_main

    assert real_study_main(["--data", str(tmp_path / "none")]) == 1
    assert real_study_main(["--checkpoint", "no_equals_sign"]) == 2
    assert real_study_main(["--table", "--out", str(tmp_path)]) == 1
    assert shipping_main(["nostudy", "c", "0", str(tmp_path / "x.pt")]) == 1
    assert shipping_main(["nostudy", "c", "zero", str(tmp_path / "x.pt")]) == 2
    lines = capsys.readouterr().err.splitlines()
    assert len(lines) == 5 and all(line.startswith("error: ") for line in lines), lines
    assert "holds no real-mesh dataset" in lines[0] and "NAME=PATH" in lines[1]
    assert "real_meshes.json" in lines[2] and "no recorded 'nostudy' study" in lines[3]


def _obj(vertices: np.ndarray) -> bytes:
    """An OBJ of the unit box's faces on ``vertices``, every digit kept."""
    lines = [f"v {x!r} {y!r} {z!r}" for x, y, z in vertices.tolist()]
    lines += [f"f {a + 1} {b + 1} {c + 1}" for a, b, c in trimesh.creation.box().faces]
    return ("\n".join(lines) + "\n").encode()


def test_models_of_no_size_or_absurd_scale_are_refused_naming_the_entry(tmp_path):
    cube = trimesh.creation.box().vertices
    cases = {
        "zero extent": (_obj(cube * 0 + 3), None, "spans 0 units, less than MIN_MODEL_EXTENT"),
        "1e-9 scale": (_obj(cube * 1e-9), None, "spans 1e-09 units, less than "
                       "MIN_MODEL_EXTENT .0.0001.: it is degenerate or in far too small units"),
        "1e300 scale": (_obj(cube * 1e300), None, "reaches 5e\\+299 units from the origin, "
                        "more than MAX_MODEL_COORDINATE"),
        "1e300 cm wide": (_obj(cube), "1e300", "scaled to its catalogue size .1e\\+300, "
                          "400.0, 100.0. cm reaches"),
    }
    for case, (obj, width, message) in cases.items():
        folder = tmp_path / case.replace(" ", "_")
        deflated_library(folder, {"test/box/box.obj": obj})
        box = read_catalogue(folder / "BlendSwap-CC-0.sh3f")[0]
        if width is not None:
            box = type(box)(**{**box.__dict__, "size_cm": (float(width), 400.0, 100.0)})
        with pytest.raises(RealMeshError, match=rf"entry #1 \(Box table\): the model "
                           f"(as stored )?{message}"):
            load_entry_mesh(box, folder)


# --- Property: any file gives a mesh or a RealMeshError naming it -----------------------------

AC3D_BYTES = AC3D.encode("latin-1")


@st.composite
def mutated_ac3d(draw) -> str:
    """The test AC3D file with a few random line edits: dropped, repeated, swapped, a
    number changed, or random text put in."""
    lines = AC3D.splitlines()
    for _ in range(draw(st.integers(1, 4))):
        k = draw(st.integers(0, len(lines) - 1))
        edit = draw(st.sampled_from(["drop", "repeat", "swap", "number", "text"]))
        if edit == "drop":
            del lines[k]
        elif edit == "repeat":
            lines.insert(k, lines[k])
        elif edit == "swap":
            j = draw(st.integers(0, len(lines) - 1))
            lines[k], lines[j] = lines[j], lines[k]
        elif edit == "number":
            words = lines[k].split() or ["x"]
            words[-1] = str(draw(st.one_of(st.integers(-10**20, 10**20),
                                           st.floats(allow_nan=True))))
            lines[k] = " ".join(words)
        else:
            lines[k] = draw(st.text(max_size=30))
        if not lines:
            break
    return "\n".join(lines)


@given(text=st.one_of(mutated_ac3d(), st.text(max_size=400),
                      st.binary(max_size=400).map(lambda b: "AC3Db\n" + b.decode("latin-1"))))
def test_any_ac3d_text_gives_a_mesh_or_an_error_naming_the_file(text):
    with no_hang():
        try:
            mesh = ac3d_to_mesh(text, "plane.ac")
        except RealMeshError as err:
            assert str(err).startswith("plane.ac"), err
        else:
            assert len(mesh.faces) > 0 and np.all(np.isfinite(mesh.vertices))


@given(garbage=st.binary(max_size=300), cut=st.integers(0, 2000),
       flips=st.lists(st.tuples(st.integers(0, 4000), st.integers(1, 255)), max_size=6),
       choice=st.sampled_from(["garbage", "mutated"]))
def test_any_library_file_gives_entries_or_an_error_naming_it(tmp_path_factory, garbage, cut,
                                                             flips, choice):
    folder = tmp_path_factory.mktemp("lib")
    path = write_library(folder)
    data = bytearray(path.read_bytes())
    if choice == "garbage":
        data = bytearray(garbage)
    else:
        for at, xor in flips:
            data[at % len(data)] ^= xor
        data = data[:len(data) - cut % len(data)] if cut % 3 == 0 else data
    path.write_bytes(bytes(data))
    try:
        entries = read_catalogue(path)
    except RealMeshError as err:
        assert str(path) in str(err), err
        return
    for entry in entries:
        try:
            mesh = load_entry_mesh(entry, folder)
        except RealMeshError as err:
            assert "BlendSwap-CC-0.sh3f" in str(err), err
        else:
            assert max(mesh.extents) == pytest.approx(1.0)


@given(text=st.one_of(st.text(max_size=300), st.binary(max_size=300)),
       header=st.booleans())
def test_any_catalogue_table_gives_rows_or_an_error_naming_it(tmp_path_factory, text,
                                                              header):
    path = tmp_path_factory.mktemp("table") / "catalogue.csv"
    head = ",".join(("id", "library", "entry_id", "name", "creator", "licence",
                     "licence_file", "category", "pose", "keep", "note")) + "\n"
    body = text.encode("utf-8") if isinstance(text, str) else text
    path.write_bytes((head.encode() if header else b"") + body)
    try:
        rows = read_mapping(path, kept_only=False)
    except RealMeshError as err:
        assert str(path) in str(err), err
    else:
        assert all(r.keep in (True, False) for r in rows)


def test_a_crrcsim_file_over_its_bound_or_not_a_file_is_refused(tmp_path, monkeypatch):
    from e2vlib.experiments.real_meshes import meshes

    (tmp_path / "plane.ac").write_text(AC3D)
    (tmp_path / "dir.ac").mkdir()
    with pytest.raises(RealMeshError, match="dir.ac is not a regular file"):
        load_entry_mesh(crrcsim_entry("dir.ac", tmp_path))
    monkeypatch.setattr(meshes, "MAX_MODEL_BYTES", 100)
    with pytest.raises(RealMeshError, match=f"plane.ac is {len(AC3D_BYTES)} bytes, more "
                       "than MAX_MODEL_BYTES .100."):
        load_entry_mesh(crrcsim_entry("plane.ac", tmp_path))


def test_real_study_writes_through_the_locked_writer_and_keeps_another_writers_scores(tmp_path):
    """Two real-mesh scorings into one file (say, two checkpoints scored at once): each
    write merges what the other wrote meanwhile, and a rescored object keeps only its new
    scores."""
    import json

    from e2vlib.experiments.real_study import _write_results

    path = tmp_path / "real_meshes.json"
    base = {"study": "real_meshes", "protocol": {"p": 1}, "checkpoints": {}, "runs": []}
    other = {"id": "a", "category": "chair", "scores": {"tiny": {"iou@0.3": 0.5}}}
    path.write_text(json.dumps({**base, "runs": [other, {"id": "b", "category": "lamp",
                                                         "scores": {"tiny": {"iou@0.3": 0.2}}}]}))
    ours = {"a": {"id": "a", "category": "chair", "scores": {"best": {"iou@0.3": 0.7}}},
            "b": {"id": "b", "category": "lamp", "scores": {"best": {"iou@0.3": 0.4}}}}
    _write_results(path, dict(base), ours, ["a", "b"], rescored={"b"})
    written = {r["id"]: r["scores"] for r in json.loads(path.read_text())["runs"]}
    assert written["a"] == {"tiny": {"iou@0.3": 0.5}, "best": {"iou@0.3": 0.7}}  # both kept
    assert written["b"] == {"best": {"iou@0.3": 0.4}}  # its old sample's score is gone
