"""The lab's commands against hostile input (issue 46): the real-object ship command, the
results-table readers, declared sensors far larger than the events, the catalogue API, the
real_objects command's error wrapper, truncated event files, checkpoints that carry a pickle
payload or odd weights."""

from __future__ import annotations

import json
import math
import os
import re
import shutil
import sys
from pathlib import Path

import numpy as np
import pytest

from e2vlib.experiments.real_objects import __main__ as real_objects_cli
from e2vlib.experiments.real_objects import ship

from .cli_run import run_main
from .conftest import REPO

SHIPPED = REPO / "data_small" / "real_objects"
UNIX = pytest.mark.skipif(not hasattr(os, "mkfifo"), reason="needs FIFOs and /dev/zero")


def run_real_objects(capsys, *argv) -> tuple[int, str, str]:
    """``python -m e2vlib.experiments.real_objects ARGV`` in-process (:func:`run_main`)."""
    return run_main(real_objects_cli.main, capsys, *argv)


# --------------------------------------------------------------------------- ship


@pytest.fixture
def scratch(tmp_path, monkeypatch):
    """A scratch folder (the working directory) holding a copy of the shipped real objects
    as the built dataset ``cache/real_objects/data``; returns that data folder."""
    data = tmp_path / "cache" / "real_objects" / "data"
    shutil.copytree(SHIPPED, data)
    monkeypatch.chdir(tmp_path)
    return data


def _first_sample(data: Path) -> Path:
    return sorted((data / "samples").glob("*.npz"))[0]


def _snapshot(folder: Path) -> dict[str, bytes]:
    return {str(p.relative_to(folder)): p.read_bytes() for p in sorted(folder.rglob("*"))
            if p.is_file() and not p.is_symlink()}


def test_ship_from_a_clean_copy_works(scratch, capsys):
    code, out, _ = run_real_objects(capsys, "ship", "--out", "shipped")
    assert code == 0, out
    assert _snapshot(Path("shipped")) == _snapshot(SHIPPED)


def test_a_sample_linked_out_of_the_data_folder_is_never_shipped(scratch, capsys, tmp_path):
    secret = tmp_path / "secret.txt"
    secret.write_text("root:x:0:0:root:/root:/bin/bash\n" * 50)
    sample = _first_sample(scratch)
    sample.unlink()
    sample.symlink_to(secret)
    code, _, err = run_real_objects(capsys, "ship", "--out", "shipped")
    assert code == 1 and sample.name in err and "outside" in err
    assert not Path("shipped").exists()


def test_a_sample_of_random_bytes_is_refused_before_copying(scratch, capsys):
    sample = _first_sample(scratch)
    sample.write_bytes(np.random.default_rng(0).bytes(5000))
    code, _, err = run_real_objects(capsys, "ship", "--out", "shipped")
    assert code == 1 and sample.name in err and "not an .npz" in err
    assert not Path("shipped").exists()


def test_a_sample_with_other_arrays_does_not_match_its_digest(scratch, capsys):
    sample = _first_sample(scratch)
    with np.load(sample) as z:
        arrays = {k: z[k] for k in z.files}
    first = sorted(arrays)[0]
    arrays[first] = np.zeros_like(arrays[first])
    np.savez_compressed(sample, **arrays)
    code, _, err = run_real_objects(capsys, "ship", "--out", "shipped")
    assert code == 1 and sample.name in err and "does not match its digest" in err
    assert not Path("shipped").exists()


@UNIX
def test_a_sample_linked_to_dev_zero_is_refused_at_once(scratch, capsys):
    sample = _first_sample(scratch)
    sample.unlink()
    sample.symlink_to("/dev/zero")
    code, _, err = run_real_objects(capsys, "ship", "--out", "shipped")
    assert code == 1 and sample.name in err
    assert not Path("shipped").exists()


@UNIX
@pytest.mark.parametrize("kind", ["fifo", "device"])
def test_a_sample_that_is_a_fifo_or_device_inside_the_folder_is_refused(scratch, capsys, kind):
    sample = _first_sample(scratch)
    sample.unlink()
    if kind == "fifo":
        os.mkfifo(sample)
    else:  # a link to a device that resolves inside the data folder
        (scratch / "zero").symlink_to("/dev/zero")
        sample.symlink_to(scratch / "zero")
    with pytest.raises(ValueError, match="FIFO|character device|outside"):
        ship.read_sample(scratch, sample.stem, "0" * 64)
    code, _, err = run_real_objects(capsys, "ship", "--out", "shipped")
    assert code == 1 and sample.name in err


def test_a_sample_over_the_size_bound_is_refused(scratch, monkeypatch, capsys):
    monkeypatch.setattr(ship, "MAX_SHIP_SAMPLE_BYTES", 1000)
    code, _, err = run_real_objects(capsys, "ship", "--out", "shipped")
    assert code == 1 and "more than the 1000 bytes" in err


@pytest.mark.parametrize("out, says", [
    ("cache/real_objects/data", "is the dataset"),
    ("cache", "holds the dataset"),
    (".", "holds the dataset"),
    ("cache/real_objects/data/inner", "lies inside the dataset"),
])
def test_ship_out_that_is_holds_or_lies_in_its_source_is_refused(scratch, capsys, out, says):
    before = _snapshot(scratch)
    code, _, err = run_real_objects(capsys, "ship", "--out", out)
    assert code == 2 and says in err and "give another folder" in err
    assert _snapshot(scratch) == before  # the source's manifest and config untouched
    with pytest.raises(ValueError, match=says):  # the API refuses it too
        ship.ship_samples(scratch, out)


def test_ship_out_through_a_link_to_its_source_is_refused(scratch, capsys, tmp_path):
    (tmp_path / "alias").symlink_to(scratch)
    code, _, err = run_real_objects(capsys, "ship", "--out", "alias")
    assert code == 2 and "is the dataset" in err


def test_ship_out_that_is_an_existing_file_is_refused_clearly(scratch, capsys):
    Path("shipped").write_text("keep me")
    code, _, err = run_real_objects(capsys, "ship", "--out", "shipped")
    assert code == 2 and "shipped is an existing file, not a folder" in err
    assert Path("shipped").read_text() == "keep me"


# ------------------------------------------------------------- the error wrapper


def test_real_objects_errors_are_one_line_and_debug_shows_the_traceback(tmp_path, capsys,
                                                                        monkeypatch):
    monkeypatch.chdir(tmp_path)  # no dataset here
    code, _, err = run_real_objects(capsys, "ship")
    assert code == 1 and "cache/real_objects/data holds no real-object dataset" in err
    code, _, err = run_real_objects(capsys, "bogus-step")
    assert code == 2 and "invalid choice" in err
    with pytest.raises(FileNotFoundError):
        real_objects_cli.main(["ship", "--debug"])


@pytest.mark.slow
def test_the_real_objects_module_fails_in_one_line_as_a_process(tmp_path):
    import subprocess

    env = {**os.environ, "PYTHONPATH": str(REPO)}
    done = subprocess.run([sys.executable, "-m", "e2vlib.experiments.real_objects", "study",
                           "--table", "--results", str(tmp_path)], capture_output=True,
                          text=True, cwd=tmp_path, env=env, timeout=120)
    assert done.returncode == 1
    assert done.stderr.count("\n") == 1 and "Traceback" not in done.stderr
    assert str(tmp_path / "real_objects.json") in done.stderr


# ------------------------------------------------------------- results-table readers


def _real_meshes_record() -> dict:
    return {"study": "real_meshes", "runs": [
        {"id": f"chair_{i}", "category": "chair",
         "scores": {"tiny": {"iou@0.3": 0.4125 + i / 100}, "visual_hull": {"iou@0.3": 0.6}}}
        for i in range(3)]}


def _real_objects_record() -> dict:
    scores = {"iou@0.3": [0.5, 0.4], "iou@val_threshold": [0.55, 0.45]}
    return {"study": "real_objects", "test_categories": ["chair", "lamp"],
            "runs": [{"config": "real", "seed": s, "metrics": {"iou@0.3": 0.4125},
                      "per_object": scores} for s in range(2)],
            "baselines": {"visual_hull": {"per_object": scores}}}


def _table(capsys, which: str, folder: Path) -> tuple[int, str, str]:
    """Print the recorded table of ``which`` (real_meshes or real_objects) in ``folder``."""
    if which == "real_objects":
        return run_real_objects(capsys, "study", "--table", "--results", folder)
    from e2vlib.experiments.real_study import main

    code = main(["--table", "--out", str(folder)])
    out, err = capsys.readouterr()
    if code != 0:
        assert len(err.strip().splitlines()) == 1 and err.startswith("error: "), err
    return code, out, err


TABLES = {"real_meshes": _real_meshes_record, "real_objects": _real_objects_record}
TEXT_CASES = {  # a results file's text -> what the one-line error says
    "nan": (lambda t: t.replace("0.4125", "NaN", 1), "is nan"),
    "overflow": (lambda t: t.replace("0.4125", "1e999", 1), "1e999 is not finite"),
    "infinity": (lambda t: t.replace("0.4125", "-Infinity", 1), "Infinity"),
    "not_json": (lambda t: t[: len(t) // 2], "not a readable results file"),
    "empty": (lambda t: "", "not a readable results file"),
    "nested": (lambda t: "[" * 100_000 + "]" * 100_000, "nested 100000 levels deep"),
    "huge_int": (lambda t: t.replace("0.4125", "9" * 5000, 1), "digits"),
    "no_runs": (lambda t: '{"study": "x"}', "holds no 'runs' list"),
    "runs_not_list": (lambda t: '{"runs": {"a": 1}}', "holds no 'runs' list"),
    "binary": (lambda t: "\udcff", "not UTF-8"),
    "list": (lambda t: "[1, 2]", "holds no 'runs' list"),
}


def _write(path: Path, text: str) -> None:
    path.write_bytes(text.encode("utf-8", "surrogateescape"))


@pytest.mark.parametrize("which", sorted(TABLES))
@pytest.mark.parametrize("case", sorted(TEXT_CASES))
def test_a_hostile_results_file_is_one_line_naming_it(capsys, tmp_path, which, case):
    change, says = TEXT_CASES[case]
    path = tmp_path / f"{which}.json"
    _write(path, change(json.dumps(TABLES[which](), indent=1)))
    code, out, err = _table(capsys, which, tmp_path)
    assert code == 1 and str(path) in err and says in err, err
    assert "nan" not in out and "inf" not in out


@pytest.mark.parametrize("which", sorted(TABLES))
def test_a_good_results_file_prints_its_table(capsys, tmp_path, which):
    (tmp_path / f"{which}.json").write_text(json.dumps(TABLES[which]()))
    code, out, _ = _table(capsys, which, tmp_path)
    assert code == 0 and ("chair" in out or "real" in out)


@pytest.mark.parametrize("which, change, says", [
    ("real_meshes", lambda r: r["runs"][0].pop("scores"), "scores is missing"),
    ("real_meshes", lambda r: r["runs"][0].update(id=["x"]), "id is ['x'], not a name"),
    ("real_meshes", lambda r: r["runs"][0]["scores"].update(tiny=[0.4]), "not the scores"),
    ("real_meshes", lambda r: r["runs"][0]["scores"]["tiny"].update({"iou@0.3": 2.5}),
     "outside [0, 1]"),
    ("real_meshes", lambda r: r.update(runs=[]), "holds no object scored"),
    ("real_objects", lambda r: r.pop("test_categories"), "test_categories is not a list"),
    ("real_objects", lambda r: r["runs"][0]["per_object"].update({"iou@0.3": [0.5]}),
     "not a list of 2 scores"),
    ("real_objects", lambda r: r["runs"][1].update(per_object={"iou@0.3": [1.5, 0.2],
                                                               "iou@val_threshold": [0, 0]}),
     "holds 1.5, not a score in [0, 1]"),
    ("real_objects", lambda r: r["baselines"].update(visual_hull=[1]), "not a record"),
    ("real_objects", lambda r: r["runs"][0].pop("metrics"), "metrics is missing"),
    ("real_objects", lambda r: r["runs"][0].update(config={"a": 1}), "not a name"),
])
def test_a_results_file_missing_what_the_table_needs_is_named(capsys, tmp_path, which,
                                                              change, says):
    record = TABLES[which]()
    change(record)
    path = tmp_path / f"{which}.json"
    path.write_text(json.dumps(record))
    code, _, err = _table(capsys, which, tmp_path)
    assert code == 1 and str(path) in err and says in err, err


@UNIX
@pytest.mark.parametrize("which", sorted(TABLES))
@pytest.mark.parametrize("kind", ["fifo", "dev_zero", "folder", "missing"])
def test_a_results_file_that_is_no_regular_file_never_hangs(capsys, tmp_path, which, kind):
    path = tmp_path / f"{which}.json"
    if kind == "fifo":
        os.mkfifo(path)
    elif kind == "dev_zero":
        path.symlink_to("/dev/zero")
    elif kind == "folder":
        path.mkdir()
    code, _, err = _table(capsys, which, tmp_path)
    assert code == 1 and str(path) in err
    assert {"fifo": "FIFO", "dev_zero": "character device", "folder": "directory",
            "missing": "`python -m e2vlib.experiments."}[kind] in err


def test_a_results_file_over_the_size_bound_is_refused(capsys, tmp_path, monkeypatch):
    from e2vlib.experiments import runner

    path = tmp_path / "real_meshes.json"
    path.write_text(json.dumps(_real_meshes_record()))
    monkeypatch.setattr(runner, "MAX_RESULTS_BYTES", 100)
    code, _, err = _table(capsys, "real_meshes", tmp_path)
    assert code == 1 and str(path) in err and "more than the 100 bytes" in err


@UNIX
def test_every_results_reader_refuses_a_fifo(tmp_path):
    from e2vlib.experiments import reports, summarize
    from e2vlib.experiments.real_objects import study
    from e2vlib.experiments.real_study import format_real_table

    path = tmp_path / "loss.json"
    os.mkfifo(path)
    for read in (lambda: reports.load_results("loss", tmp_path), lambda: summarize(path),
                 lambda: format_real_table(path), lambda: study.read_table(path)):
        with pytest.raises(ValueError, match="FIFO"):
            read()


# ------------------------------------------------------------------ the catalogue API

CATALOGUE_ROW = {"id": "airplane_fgbase_plane", "source": "flightgear-data-base",
                 "path": "plane.ac", "licence": "GPL-2.0-or-later", "category": "airplane",
                 "rotation": "", "removed": "", "keep": "yes", "split": "train",
                 "note": "looked: a small plane"}
PLANE = """AC3Db
OBJECT world
kids 1
OBJECT poly
numvert 4
-0.5 0 -0.2
0.5 0 -0.2
0.5 0 0.2
-0.5 0 0.2
numsurf 1
SURF 0x10
mat 0
refs 4
0 0 0
1 0 0
2 0 0
3 0 0
kids 0
"""


@pytest.mark.parametrize("path", ["/etc/passwd", "../../x.ac", "models/../../../x.ac",
                                  "z.zip::../../x.ac", "z.zip::/abs.ac", "C:/x.ac",
                                  "models\\..\\..\\x.ac", "z.zip::", "a::b::c"])
def test_read_catalogue_refuses_a_path_leaving_its_package(tmp_path, path):
    from e2vlib.experiments.real_meshes.catalogue import RealMeshError
    from e2vlib.experiments.real_objects import catalogue as cat

    table = tmp_path / "catalogue.csv"
    table.write_text(",".join(cat.FIELDS) + "\n" + ",".join(
        f'"{v}"' for v in {**CATALOGUE_ROW, "path": path}.values()) + "\n")
    with pytest.raises(RealMeshError, match=r"catalogue.csv: 1 bad row\(s\): line 2: path "):
        cat.read_catalogue(table)
    good = tmp_path / "good.csv"
    good.write_text(table.read_text().replace(path.replace('"', ""), "plane.ac"))
    assert [r.path for r in cat.read_catalogue(good)] == ["plane.ac"]


@pytest.mark.parametrize("how", ["climbs", "absolute", "member", "link"])
def test_load_row_mesh_reads_only_inside_the_package_folder(tmp_path, how):
    from e2vlib.experiments.real_meshes.catalogue import RealMeshError
    from e2vlib.experiments.real_objects import samples
    from e2vlib.experiments.real_objects.catalogue import RealObject

    package = tmp_path / "cache" / "pkgs" / "flightgear-data-base"
    package.mkdir(parents=True)
    outside = tmp_path / "outside.ac"
    outside.write_text(PLANE)
    (package / "plane.ac").write_text(PLANE)
    path = {"climbs": "../../../outside.ac", "absolute": str(outside),
            "member": "z.zip::../../outside.ac", "link": "linked.ac"}[how]
    (package / "linked.ac").symlink_to(outside)
    fields = {k: v for k, v in CATALOGUE_ROW.items() if k != "keep"}
    row = RealObject(**{**fields, "path": path}, keep=True)
    with pytest.raises(RealMeshError, match="climbs out|is absolute|leads outside its package"):
        samples.load_row_mesh(tmp_path / "cache", row)
    fine = RealObject(**fields, keep=True)
    assert len(samples.load_row_mesh(tmp_path / "cache", fine).vertices) >= 4


# ------------------------------------------------- a declared sensor far larger than the events


@pytest.mark.slow  # (runs the model once, for the same events on their own sensor)
def test_events_in_a_corner_of_a_declared_sensor_are_refused_naming_the_file(capsys,
                                                                             tmp_path):
    from e2vlib.io import load_events, save_events

    from .test_cli import run

    events, sensor = load_events(REPO / "data_small" / "events" / "lamp_0013.npz")
    assert sensor == (128, 128) and events["x"].max() < 128
    big, out = tmp_path / "lamp_4000.npz", tmp_path / "r.npz"
    save_events(big, events, (4000, 4000))
    checkpoint = REPO / "data_small" / "checkpoints" / "e2v_tiny.pt"
    code, _, err = run(capsys, "reconstruct", "--checkpoint", checkpoint, "--events", big,
                       "--out", out, "--device", "cpu")
    assert code == 1 and str(big) in err and not out.exists()
    x, y = events["x"], events["y"]
    assert (f"they lie within x {x.min()}-{x.max()}, y {y.min()}-{y.max()} of the declared "
            "4000 x 4000 sensor") in err
    assert f"(at least {x.max() + 1} x {y.max() + 1})" in err
    # the same events declared with the sensor that recorded them give an answer
    code, _, err = run(capsys, "reconstruct", "--checkpoint", checkpoint, "--events",
                       REPO / "data_small" / "events" / "lamp_0013.npz", "--out", out,
                       "--device", "cpu")
    assert code == 0 and out.exists(), err


def test_events_that_fill_a_quarter_of_the_frame_pass_the_spread_check():
    from e2vlib.events import make_events
    from e2vlib.experiments.reconstruct import InputError, check_events_spread

    # a 40 x 32 sensor: the centred 32 x 32 square (columns 4-35) pooled by 2 to 16 px
    events = make_events([4, 11], [2, 2], [0, 10], [1, 1])  # pixels 0 and 3: 4 px across
    check_events_spread(events, (40, 32), 16, "ok.npz")
    events = make_events([4, 9, 39], [2, 2, 2], [0, 10, 20], [1, 1, 1])  # 3 px, one outside
    with pytest.raises(InputError, match=r"^events small.npz: they lie within x 4-39, y 2-2 "
                                         r"of the declared 40 x 32 sensor, so the model's 16 x "
                                         r"16 px frames see them in 3 x 1 px"):
        check_events_spread(events, (40, 32), 16, "small.npz")


# ------------------------------------------------------------------------ event files

FORMATS = (".npz", ".txt", ".txt.gz", ".h5")


@pytest.fixture(scope="module")
def tiny():
    """data_small's tiny checkpoint, read once."""
    from e2vlib.model import read_checkpoint

    return read_checkpoint(REPO / "data_small" / "checkpoints" / "e2v_tiny.pt")


def _lamp():
    from e2vlib.io import load_events

    return load_events(REPO / "data_small" / "events" / "lamp_0013.npz")[0]


def test_an_npz_whose_header_declares_more_than_it_holds_is_called_truncated(tmp_path):
    import io
    import zipfile

    from e2vlib.events import make_events
    from e2vlib.io import load_events, save_events

    k = np.arange(1000)
    good, liar = tmp_path / "good.npz", tmp_path / "liar.npz"
    save_events(good, make_events(k % 16, k % 16, 10 * k, np.ones(1000)), (16, 16))
    with zipfile.ZipFile(good) as src, zipfile.ZipFile(liar, "w") as out:
        for name in src.namelist():
            data = src.read(name)
            if name == "t.npy":  # a header declaring 100 x the values the member holds
                array = np.load(io.BytesIO(data))
                header = io.BytesIO()
                np.lib.format.write_array_header_1_0(header, {
                    "descr": np.lib.format.dtype_to_descr(array.dtype),
                    "fortran_order": False, "shape": (100 * len(array),)})
                data = header.getvalue() + array.tobytes()
            out.writestr(name, data)
    with pytest.raises(ValueError, match=r"liar.npz: truncated: the array 't' declares "
                                         r"\[100000\] values of int64 \(800000 bytes\) but "
                                         r"holds 8000 bytes"):
        load_events(liar)


def test_a_text_event_file_over_the_line_bound_is_refused(tmp_path, monkeypatch):
    import gzip

    from e2vlib import io as event_io

    monkeypatch.setattr(event_io, "MAX_TEXT_EVENTS", 1000)
    for name, opener in (("many.txt", open), ("many.txt.gz", gzip.open)):
        path = tmp_path / name
        with opener(path, "wt") as f:  # a few kB of gzip that unpack to many lines
            f.write("16 16\n" + "0.001 1 1 1\n" * 1001)
        with pytest.raises(ValueError, match=rf"{name}: more than io.MAX_TEXT_EVENTS = 1000"):
            event_io.load_events(path)
        with opener(path, "wt") as f:
            f.write("16 16\n" + "0.001 1 1 1\n" * 1000)
        assert len(event_io.load_events(path)[0]) == 1000


@pytest.mark.parametrize("suffix", [".txt.gz", ".h5", ".npz"])
def test_a_cut_short_event_file_is_called_truncated(tmp_path, suffix):
    from e2vlib.io import load_events, save_events

    path = tmp_path / f"lamp{suffix}"
    save_events(path, _lamp(), (128, 128))
    data = path.read_bytes()
    path.write_bytes(data[: len(data) // 2])
    with pytest.raises(ValueError, match=rf"lamp{suffix}: corrupted or truncated"):
        load_events(path)


def test_an_hdf5_file_declaring_gigabytes_is_refused_from_its_headers(tmp_path):
    import h5py

    from e2vlib.io import load_events

    path = tmp_path / "bomb.h5"
    with h5py.File(path, "w") as f:  # chunked and never written: a few kB on disk
        for name, dtype in (("x", "u2"), ("y", "u2"), ("t", "i8"), ("p", "i1")):
            f.create_dataset(f"events/{name}", shape=(1 << 30,), dtype=dtype, chunks=(1024,))
        f.attrs.update(width=16, height=16)
    assert path.stat().st_size < 1 << 20
    with pytest.raises(ValueError, match=r"bomb.h5: the event arrays declare 13 GiB .*"
                                         r"MAX_EVENT_BYTES"):
        load_events(path)


@pytest.mark.parametrize("suffix", FORMATS)
def test_every_format_with_a_far_larger_declared_sensor_is_refused(tmp_path, suffix, tiny):
    from e2vlib.experiments.reconstruct import InputError, reconstruct
    from e2vlib.io import save_events

    path = tmp_path / f"lamp{suffix}"
    save_events(path, _lamp(), (4000, 4000))
    with pytest.raises(InputError, match=rf"^events {path}: they lie within .* of the "
                                         r"declared 4000 x 4000 sensor"):
        reconstruct(tiny, events=path, device="cpu")


@pytest.mark.parametrize("suffix", FORMATS)
def test_every_format_with_bunched_or_offset_events_is_refused(tmp_path, suffix, tiny):
    from e2vlib.experiments.reconstruct import InputError, reconstruct
    from e2vlib.io import save_events

    events = _lamp()
    events["t"][1:] += 60_000_000  # one stray event a minute before the orbit
    path = tmp_path / f"lamp{suffix}"
    save_events(path, events, (128, 128))
    with pytest.raises(InputError, match=rf"^events {path}: only 1 of the model's 100 frames"):
        reconstruct(tiny, events=path, device="cpu")


# ------------------------------------------------------------------------ checkpoints

REFUSED = {  # variant -> what the one-line refusal says
    "pickle": "holds Python objects besides weights",
    "int32": "holds torch.int32 values where the model has torch.float32",
    "nan": "holds non-finite weights",
    "truncated": "corrupted, truncated or not a torch file",
    "empty": "is empty (0 bytes)",
    "random": "corrupted or not a torch file",  # not "holds Python objects": it asks for none
}


class _Payload:
    """Unpickling this writes the file ``marker``: proof that code in a checkpoint ran."""

    def __init__(self, marker: Path) -> None:
        self.marker = marker

    def __reduce__(self):
        return (exec, (f"open({str(self.marker)!r}, 'w').write('ran')",))


@pytest.fixture(scope="module")
def variants(tmp_path_factory):
    """data_small's tiny checkpoint changed: a pickle payload, int32 / float64 / bf16 / NaN
    weights (no digest, as another program would write them), cut in half, empty, random
    bytes."""
    import torch

    from e2vlib.model import read_checkpoint

    folder = tmp_path_factory.mktemp("checkpoints")
    source = REPO / "data_small" / "checkpoints" / "e2v_tiny.pt"
    ckpt = read_checkpoint(source)
    optimizer = torch.optim.AdamW([torch.zeros(1, requires_grad=True)])
    ckpt.update(optimizer=optimizer.state_dict(), epoch=1, best_iou=0.1, history=[],
                torch_rng=torch.get_rng_state())  # each is also a last.pt to resume from
    torch.save({**ckpt, "note": _Payload(folder / "RAN")}, folder / "pickle.pt")
    casts = {"int32": lambda t: t.to(torch.int32), "float64": lambda t: t.double(),
             "bf16": lambda t: t.bfloat16(), "nan": lambda t: torch.full_like(t, math.nan)}
    for name, cast in casts.items():
        plain = {k: v for k, v in ckpt.items() if k != "weights_sha256"}
        plain["model"] = {k: cast(v) if v.is_floating_point() else v
                          for k, v in ckpt["model"].items()}
        torch.save(plain, folder / f"{name}.pt")
    data = source.read_bytes()
    (folder / "truncated.pt").write_bytes(data[: len(data) // 2])
    (folder / "empty.pt").write_bytes(b"")
    (folder / "random.pt").write_bytes(np.random.default_rng(0).bytes(5000))
    return folder


def _entry_points(checkpoint: Path, tmp_path: Path) -> dict[str, list]:
    """Each command line that reads ``checkpoint`` (train --resume reads OUT/last.pt)."""
    run_dir = tmp_path / "run"
    run_dir.mkdir(exist_ok=True)
    shutil.copy(checkpoint, run_dir / "last.pt")
    data = REPO / "data_small"
    return {
        "reconstruct": ["reconstruct", "--checkpoint", checkpoint, "--events",
                        data / "events" / "lamp_0013.npz", "--out", tmp_path / "r.npz",
                        "--device", "cpu"],
        "evaluate": ["evaluate", "--checkpoint", checkpoint, "--data", data, "--split", "test",
                     "--device", "cpu"],
        "figures": ["figures", "--checkpoint", checkpoint, "--out", tmp_path / "figures"],
        "train --resume": ["train", "--data", data, "--out", run_dir, "--resume", "--epochs",
                           "1", "--device", "cpu"],
    }


@pytest.mark.parametrize("variant", sorted(REFUSED))
def test_a_bad_checkpoint_is_refused_by_every_command_naming_it(capsys, tmp_path, variants,
                                                                variant):
    from .test_cli import run

    checkpoint = variants / f"{variant}.pt"
    for command, argv in _entry_points(checkpoint, tmp_path).items():
        code, out, err = run(capsys, *argv)
        named = tmp_path / "run" / "last.pt" if command == "train --resume" else checkpoint
        assert code == 1 and str(named) in err and REFUSED[variant] in err, (command, err)
    assert not (variants / "RAN").exists()  # the payload never ran
    assert not (tmp_path / "r.npz").exists() and not (tmp_path / "figures").exists()


@pytest.mark.parametrize("variant", sorted(REFUSED))
def test_lesson_14s_fine_tuning_start_refuses_a_bad_checkpoint(tmp_path, variants, variant):
    from e2vlib.experiments.real_objects import study
    from e2vlib.model import CheckpointError, load_checkpoint

    with pytest.raises(CheckpointError, match=re.escape(REFUSED[variant])):
        load_checkpoint(variants / f"{variant}.pt")  # what lesson 14 fine-tunes from
    start = study.checkpoint_path(tmp_path, "procedural", 0)
    shutil.copy(variants / f"{variant}.pt", start)
    with pytest.raises(CheckpointError, match=re.escape(REFUSED[variant])):  # the study's
        study.run_config("fine_tuned", 0, {"real": {"train": None, "val": None}},
                         tmp_path, quick=True)
    assert not (variants / "RAN").exists()


@pytest.mark.slow
@pytest.mark.parametrize("variant, tolerance", [("float64", 1e-6), ("bf16", 0.05)])
def test_float64_and_bf16_weights_give_the_float32_models_answer(variants, variant,
                                                                 tolerance):
    from e2vlib.experiments.reconstruct import reconstruct
    from e2vlib.model import load_checkpoint

    events = REPO / "data_small" / "events" / "lamp_0013.npz"
    model = load_checkpoint(variants / f"{variant}.pt")
    assert {p.dtype for p in model.parameters()} == {next(iter(model.parameters())).dtype}
    reference = reconstruct(REPO / "data_small" / "checkpoints" / "e2v_tiny.pt", events=events,
                            device="cpu").probabilities
    answer = reconstruct(variants / f"{variant}.pt", events=events, device="cpu").probabilities
    assert answer.dtype == np.float32
    assert np.abs(answer - reference).max() < tolerance


def test_resuming_from_int32_weights_is_refused_by_the_library_too(variants):
    import torch

    from e2vlib.model import CheckpointError, load_checkpoint, read_checkpoint
    from e2vlib.scale.training import LEGACY_LOSS, read_resume_state

    model = load_checkpoint(variants / "float64.pt")  # the same model, float weights
    loss = read_checkpoint(variants / "float64.pt").get("loss", LEGACY_LOSS)
    with pytest.raises(CheckpointError, match="holds torch.int32 values where the model has "
                                              "torch.float32"):
        read_resume_state(variants / "int32.pt", model, None, torch.device("cpu"), loss)


@pytest.mark.parametrize("key, value", [("epoch", "three"), ("epoch", 2.5), ("best_iou", None),
                                        ("history", "none")])
def test_resuming_from_a_last_pt_with_damaged_bookkeeping_names_the_file(tmp_path, variants,
                                                                         key, value):
    import torch

    from e2vlib.model import CheckpointError, load_checkpoint, read_checkpoint
    from e2vlib.scale.training import LEGACY_LOSS, read_resume_state

    state = read_checkpoint(variants / "float64.pt", verify=False)
    model = load_checkpoint(variants / "float64.pt")
    loss = state.get("loss", LEGACY_LOSS)
    good = tmp_path / "good.pt"
    torch.save({**state, "model": model.state_dict()}, good)
    assert read_resume_state(good, model, None, torch.device("cpu"), loss)["epoch"] == 1
    bad = tmp_path / "last.pt"
    torch.save({**state, "model": model.state_dict(), key: value}, bad)
    with pytest.raises(CheckpointError, match=rf"^cannot resume from {re.escape(str(bad))}: "
                                              rf"its {key} is "):
        read_resume_state(bad, model, None, torch.device("cpu"), loss)
