import gzip

import h5py
import numpy as np
import pytest

from e2vlib.events import EVENT_DTYPE, EventError
from e2vlib.io import load_events, save_events

from .conftest import REAL_RECORDING


@pytest.mark.parametrize("name", ["ev.npz", "ev.txt", "ev.txt.gz", "ev.h5"])
def test_round_trip(tmp_path, random_events, name):
    ev, size = random_events
    path = save_events(tmp_path / name, ev, size)
    loaded, loaded_size = load_events(path)
    assert loaded.dtype == EVENT_DTYPE and loaded_size == size
    np.testing.assert_array_equal(loaded, ev)
    assert [p.name for p in tmp_path.iterdir()] == [name]  # no temporary file left behind


def test_rpg_text_converts_seconds_and_01_polarity(tmp_path):
    path = tmp_path / "events.txt"
    path.write_text("240 180\n0.000001 3 4 1\n0.5 10 20 0\n1.25 239 179 1\n")
    ev, size = load_events(path)
    assert size == (240, 180)
    assert ev["t"].tolist() == [1, 500_000, 1_250_000]
    assert ev["p"].tolist() == [1, -1, 1]
    assert ev["x"].tolist() == [3, 10, 239] and ev["y"].tolist() == [4, 20, 179]


def test_headerless_esim_text_and_gzip(tmp_path):
    path = tmp_path / "events.txt.gz"
    with gzip.open(path, "wt") as f:
        f.write("0.1 5 6 0\n0.2 7 8 1\n")
    ev, size = load_events(path)
    assert size == (8, 9)  # inferred: the smallest sensor holding every event
    assert ev["t"].tolist() == [100_000, 200_000] and ev["p"].tolist() == [-1, 1]


def test_unsorted_file_comes_back_sorted(tmp_path):
    path = tmp_path / "events.txt"
    path.write_text("4 4\n0.3 1 1 1\n0.1 2 2 0\n0.2 3 3 1\n")
    ev, _ = load_events(path)
    assert ev["t"].tolist() == [100_000, 200_000, 300_000]
    assert ev["x"].tolist() == [2, 3, 1]


def test_v2e_style_hdf5_table(tmp_path):
    path = tmp_path / "v2e.h5"
    with h5py.File(path, "w") as f:  # v2e: (N, 4) uint32 rows of t (us), x, y, p (0/1)
        f.create_dataset("events", data=np.array([[10, 1, 2, 1], [30, 3, 0, 0]], np.uint32))
    ev, size = load_events(path)
    assert ev["t"].tolist() == [10, 30] and ev["p"].tolist() == [1, -1]
    assert size == (4, 3)


def test_dsec_style_hdf5_with_offset(tmp_path):
    path = tmp_path / "dsec.h5"
    with h5py.File(path, "w") as f:
        g = f.create_group("events")
        g["x"] = np.array([5, 6], np.uint16)
        g["y"] = np.array([7, 8], np.uint16)
        g["t"] = np.array([0, 1000], np.uint32)
        g["p"] = np.array([1, 0], np.uint8)
        f["t_offset"] = np.int64(1_000_000)
        g.attrs["width"], g.attrs["height"] = 640, 480
    ev, size = load_events(path)
    assert ev["t"].tolist() == [1_000_000, 1_001_000] and ev["p"].tolist() == [1, -1]
    assert size == (640, 480)


def test_hdf5_float_seconds_and_explicit_unit(tmp_path):
    path = tmp_path / "sec.h5"
    with h5py.File(path, "w") as f:
        g = f.create_group("events")
        g["x"], g["y"] = np.array([0, 1]), np.array([0, 1])
        g["t"], g["p"] = np.array([0.5, 1.5]), np.array([True, False])
    assert load_events(path)[0]["t"].tolist() == [500_000, 1_500_000]
    with h5py.File(path, "a") as f:
        del f["events/t"]
        f["events/t"] = np.array([2000, 3000])
        f["events"].attrs["t_unit"] = "ns"
    assert load_events(path)[0]["t"].tolist() == [2, 3]


def test_real_davis_recording():
    ev, size = load_events(REAL_RECORDING)
    assert size == (346, 260)  # DAVIS346
    assert len(ev) == 78_830
    assert set(np.unique(ev["p"]).tolist()) == {-1, 1}
    assert np.all(np.diff(ev["t"]) >= 0)
    assert (ev["t"][-1] - ev["t"][0]) == pytest.approx(2.36e6, rel=0.01)  # about 2.4 s


@pytest.mark.parametrize("name", ["ev.npz", "ev.txt.gz", "ev.h5"])
def test_truncated_files_raise_naming_the_file(tmp_path, random_events, name):
    ev, size = random_events
    path = save_events(tmp_path / name, ev, size)
    data = path.read_bytes()
    path.write_bytes(data[: len(data) // 2])
    with pytest.raises(ValueError, match=name):
        load_events(path)


def test_truncated_aedat4_raises(tmp_path):
    path = tmp_path / "cut.aedat4"
    path.write_bytes(REAL_RECORDING.read_bytes()[:100])
    with pytest.raises(ValueError, match="cut.aedat4"):
        load_events(path)


def test_garbage_text_raises(tmp_path):
    path = tmp_path / "bad.txt"
    path.write_text("346 260\n0.1 1 1 1\n0.2 abc 1 1\n")
    with pytest.raises(ValueError, match="bad.txt"):
        load_events(path)


def test_pixels_outside_declared_sensor_raise(tmp_path):
    path = tmp_path / "big.txt"
    path.write_text("10 10\n0.1 1 1 1\n0.2 12 1 1\n")
    with pytest.raises(EventError, match="big.txt.*outside"):
        load_events(path)


def test_missing_unknown_and_unwritable_formats(tmp_path, small_events):
    with pytest.raises(FileNotFoundError):
        load_events(tmp_path / "nope.npz")
    with pytest.raises(ValueError, match="unknown event file type"):
        load_events(tmp_path / "x.csv")
    with pytest.raises(ValueError, match="not supported"):
        save_events(tmp_path / "x.aedat4", small_events, (4, 3))


def test_failed_write_keeps_existing_file(tmp_path, small_events):
    path = save_events(tmp_path / "keep.npz", small_events, (4, 3))
    before = path.read_bytes()
    with pytest.raises(EventError):
        save_events(path, small_events, (2, 2))  # invalid: pixels outside
    bad = small_events.copy()
    bad["p"][0] = 0
    with pytest.raises(EventError):
        save_events(path, bad, (4, 3))
    assert path.read_bytes() == before
    assert len(list(tmp_path.iterdir())) == 1


def test_crash_during_write_keeps_existing_file(tmp_path, small_events, monkeypatch):
    import e2vlib.io as eio

    path = save_events(tmp_path / "keep.npz", small_events, (4, 3))
    before = path.read_bytes()

    def crashing_writer(tmp, events, sensor_size):
        tmp.write_bytes(b"half a file")
        raise KeyboardInterrupt

    monkeypatch.setattr(eio, "_write_npz", crashing_writer)
    with pytest.raises(KeyboardInterrupt):
        save_events(path, small_events, (4, 3))
    assert path.read_bytes() == before
    assert [p.name for p in tmp_path.iterdir()] == ["keep.npz"]
