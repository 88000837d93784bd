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


# --- times: exact scaling, offsets and int64 overflow (issue 14) -----------------------------


def _dsec_file(path, t, t_offset, t_unit=None, offset_unit=None):
    with h5py.File(path, "w") as f:
        g = f.create_group("events")
        g["x"] = np.arange(len(t)) % 4
        g["y"] = np.zeros(len(t), np.uint16)
        g["t"] = t
        g["p"] = np.ones(len(t), np.uint8)
        f["t_offset"] = t_offset
        if t_unit:
            g.attrs["t_unit"] = t_unit
        if offset_unit:
            f["t_offset"].attrs["t_unit"] = offset_unit
    return path


def test_hdf5_float_seconds_plus_offset_keep_their_times(tmp_path):
    # t in float seconds, DSEC's t_offset in int64 microseconds: scale t first, then add
    path = _dsec_file(tmp_path / "sec_offset.h5", np.array([0.5, 1.5, 1.500001]),
                      np.int64(1_000_000))
    ev, _ = load_events(path)
    assert ev["t"].tolist() == [1_500_000, 2_500_000, 2_500_001]


def test_hdf5_offset_in_its_own_unit(tmp_path):
    path = _dsec_file(tmp_path / "float_offset.h5", np.array([0, 250], np.int64),
                      np.float64(2.5))  # a float offset without a unit is in seconds
    assert load_events(path)[0]["t"].tolist() == [2_500_000, 2_500_250]
    path = _dsec_file(tmp_path / "ms.h5", np.array([1, 2], np.int64), np.int64(3),
                      t_unit="ms", offset_unit="ms")
    assert load_events(path)[0]["t"].tolist() == [4000, 5000]


def test_hdf5_offset_overflow_raises_naming_the_range(tmp_path):
    path = _dsec_file(tmp_path / "big.h5", np.array([0, 1000], np.uint32),
                      np.int64(2**63 - 1))
    with pytest.raises(EventError, match=r"big.h5: t \+ offset .*int64 microsecond range"):
        load_events(path)
    path = _dsec_file(tmp_path / "edge.h5", np.array([0], np.uint32), np.int64(2**63 - 1))
    assert load_events(path)[0]["t"].tolist() == [2**63 - 1]  # exactly the largest time


def test_hdf5_nanoseconds_and_large_values_are_exact(tmp_path):
    t_ns = np.array([1_700_000_000_123_456_789, 1_700_000_000_123_457_500], np.int64)
    path = tmp_path / "ns.h5"
    with h5py.File(path, "w") as f:
        g = f.create_group("events")
        g["x"], g["y"], g["t"], g["p"] = [0, 1], [0, 0], t_ns, [1, 0]
        g.attrs["t_unit"] = "ns"
    # float64 arithmetic would be off by up to 128 ns here; halves round to even
    assert load_events(path)[0]["t"].tolist() == [1_700_000_000_123_457, 1_700_000_000_123_458]


@pytest.mark.parametrize("t, dtype", [(2.0**63, np.float64), (2**63, np.uint64),
                                      (1e19, np.float64)])
def test_hdf5_times_beyond_int64_raise(tmp_path, t, dtype):
    path = tmp_path / "far.h5"
    with h5py.File(path, "w") as f:
        g = f.create_group("events")
        g["x"], g["y"], g["p"] = [0], [0], [1]
        g["t"] = np.array([t], dtype)
        g.attrs["t_unit"] = "us"
    with pytest.raises(EventError, match="far.h5: t: 1 values outside the int64"):
        load_events(path)


def test_text_times_at_the_ends_of_int64_are_exact(tmp_path):
    path = tmp_path / "edge.txt"
    # 9223372036854.775807 s is exactly int64's largest microsecond: float64 would round
    # it to 2**63 (which wrapped around to -2**63); it is read digit by digit instead
    path.write_text("4 4\n-9223372036854.775808 1 1 0\n9223372036854.775807 2 1 1\n")
    ev, _ = load_events(path)
    assert ev["t"].tolist() == [-2**63, 2**63 - 1]


@pytest.mark.parametrize("line", ["9223372036854.775808 1 1 1", "-9223372036854.775809 1 1 1",
                                  "1e20 1 1 1"])
def test_text_times_beyond_int64_raise_naming_the_range(tmp_path, line):
    path = tmp_path / "far.txt"
    path.write_text(f"4 4\n0.5 1 1 1\n{line}\n")
    with pytest.raises(EventError, match=r"far.txt: t: 1 values outside the int64 microsecond "
                                         r"range \[-9223372036854775808, 9223372036854775807\]"):
        load_events(path)


def test_text_round_trip_of_huge_times(tmp_path):
    from e2vlib.events import make_events

    t = np.array([-2**63, -1, 0, 1, 2**53 + 1, 2**62 + 3, 2**63 - 1], np.int64)
    ev = make_events(np.zeros(7), np.zeros(7), t, np.ones(7))
    for name in ("huge.txt", "huge.txt.gz"):
        np.testing.assert_array_equal(load_events(save_events(tmp_path / name, ev, (1, 1)))[0],
                                      ev)
    assert (tmp_path / "huge.txt").read_text().splitlines()[1:3] == [
        "-9223372036854.775808 0 0 1", "-0.000001 0 0 1"]


def test_text_times_with_more_digits_round_to_the_microsecond(tmp_path):
    path = tmp_path / "ns.txt"
    path.write_text("4 4\n0.0000014 1 1 1\n0.0000016 1 1 1\n1e-3 1 1 1\n")
    assert load_events(path)[0]["t"].tolist() == [1, 2, 1000]


def test_aedat4_times_go_through_the_checked_conversion(monkeypatch):
    import e2vlib.io as eio

    calls = []
    real = eio.times_to_us

    def spy(t, unit="us", name="t"):
        calls.append(unit)
        return real(t, unit, name)

    monkeypatch.setattr(eio, "times_to_us", spy)
    load_events(REAL_RECORDING)
    assert calls == ["us"]


# --- text headers, file types and folders: errors naming the file, line and fix -----------


@pytest.mark.parametrize("header", ["50.5 40", "width height", "346 0", "-3 4", "346 260.0"])
def test_bad_text_header_names_file_line_and_fix(tmp_path, header):
    path = tmp_path / "hdr.txt"
    path.write_text(f"{header}\n0.1 1 1 1\n")
    with pytest.raises(ValueError, match=r"hdr.txt, line 1: the first line must be the sensor "
                                         r"size 'width height' in whole pixels .*346 260") as info:
        load_events(path)
    assert repr(header) in str(info.value)
    assert "invalid literal" not in str(info.value)


def test_header_after_comments_names_its_line(tmp_path):
    path = tmp_path / "hdr.txt"
    path.write_text("# recorded with a DAVIS346\n\n346 260.5\n0.1 1 1 1\n")
    with pytest.raises(ValueError, match="hdr.txt, line 3: "):
        load_events(path)
    path.write_text("# recorded with a DAVIS346\n346 260\n0.1 1 1 1\n")
    assert load_events(path)[1] == (346, 260)


def test_header_with_three_values_names_the_layouts(tmp_path):
    path = tmp_path / "three.txt"
    path.write_text("346 260 1\n0.1 1 1 1\n")
    with pytest.raises(ValueError, match=r"three.txt, line 1: expected the sensor size "
                                         r"'width height' .* or an event 't x y p', got 3"):
        load_events(path)


@pytest.mark.parametrize("name", ["bom.txt", "bom.txt.gz"])
def test_utf8_byte_order_mark_is_accepted(tmp_path, name):
    path = tmp_path / name
    text = "\ufeff240 180\n0.5 3 4 1\n"
    if name.endswith(".gz"):
        with gzip.open(path, "wt", encoding="utf-8") as f:
            f.write(text)
    else:
        path.write_text(text, encoding="utf-8")
    ev, size = load_events(path)
    assert size == (240, 180) and ev["t"].tolist() == [500_000]


def test_byte_order_mark_before_headerless_events(tmp_path):
    path = tmp_path / "esim.txt"
    path.write_bytes(b"\xef\xbb\xbf0.5 3 4 1\n0.6 1 1 0\n")
    ev, size = load_events(path)
    assert ev["x"].tolist() == [3, 1] and size == (4, 5)


def test_bad_data_line_names_its_line_number(tmp_path):
    path = tmp_path / "rows.txt"
    path.write_text("4 4\n0.1 1 1 1\n# a comment\n\n0.2 1 x 1\n")
    with pytest.raises(ValueError, match=r"rows.txt, line 5: expected 4 numbers 't x y p', "
                                         r"got '0.2 1 x 1'"):
        load_events(path)
    path.write_text("4 4\n0.1 1 1 1\n0.2 1 1\n")
    with pytest.raises(ValueError, match=r"rows.txt, line 3: expected 4 columns 't x y p', "
                                         r"found 3"):
        load_events(path)


def test_empty_text_files(tmp_path):
    path = tmp_path / "empty.txt"
    path.write_text("")
    with pytest.raises(ValueError, match="empty.txt: the file is empty"):
        load_events(path)
    path.write_text("# nothing here\n\n")
    with pytest.raises(ValueError, match="empty.txt: no header and no events"):
        load_events(path)
    path.write_text("8 6\n")  # a header and no events: a valid empty recording
    ev, size = load_events(path)
    assert len(ev) == 0 and size == (8, 6)


def test_hdf5_renamed_npz_says_it_is_hdf5(tmp_path, random_events):
    ev, size = random_events
    path = save_events(tmp_path / "ev.h5", ev, size).rename(tmp_path / "ev.npz")
    with pytest.raises(ValueError, match="ev.npz: this is an HDF5 file; rename it .h5") as info:
        load_events(path)
    assert "pickle" not in str(info.value)


@pytest.mark.parametrize("saved, renamed, says", [
    ("ev.npz", "ev.h5", "this is a zip"),
    ("ev.npz", "ev.txt", "this is a zip"),
    ("ev.txt", "ev.npz", "this is a text file; .* rename it .txt"),
    ("ev.txt", "ev.txt.gz", "this is plain text, not gzip-compressed; rename it .txt"),
    ("ev.txt.gz", "ev.txt", "this is a gzip file; .* rename it .txt.gz"),
    ("ev.h5", "ev.aedat4", "this is an HDF5 file"),
])
def test_renamed_files_name_their_real_format(tmp_path, random_events, saved, renamed, says):
    ev, size = random_events
    path = save_events(tmp_path / saved, ev, size).rename(tmp_path / renamed)
    with pytest.raises(ValueError, match=f"{renamed}: {says}"):
        load_events(path)


def test_aedat4_renamed_and_npy_files(tmp_path):
    path = tmp_path / "rec.h5"
    path.write_bytes(REAL_RECORDING.read_bytes()[:4096])
    with pytest.raises(ValueError, match="rec.h5: this is an AEDAT4 recording; rename it"):
        load_events(path)
    path = tmp_path / "arr.npz"
    with open(path, "wb") as f:
        np.save(f, np.zeros(3))
    with pytest.raises(ValueError, match="arr.npz: this is a single .npy array"):
        load_events(path)
    path = tmp_path / "zero.npz"
    path.write_bytes(b"")
    with pytest.raises(ValueError, match="zero.npz: the file is empty"):
        load_events(path)
    path = tmp_path / "junk.txt"
    path.write_bytes(bytes(range(8)) * 4)
    with pytest.raises(ValueError, match="junk.txt: not a text event file"):
        load_events(path)


def test_sniff_format_knows_every_writable_format(tmp_path, small_events):
    from e2vlib.io import sniff_format

    kinds = {"a.npz": "npz", "a.txt": "text", "a.txt.gz": "gzip", "a.h5": "hdf5"}
    for name, kind in kinds.items():
        assert sniff_format(save_events(tmp_path / name, small_events, (4, 3))) == kind
    assert sniff_format(REAL_RECORDING) == "aedat4"


def test_directory_named_like_an_event_file_says_it_is_a_directory(tmp_path):
    folder = tmp_path / "x.npz"
    folder.mkdir()
    with pytest.raises(IsADirectoryError, match="x.npz is a directory, not an event file"):
        load_events(folder)
    with pytest.raises(IsADirectoryError, match="x.npz is a directory"):
        save_events(folder, np.zeros(0, EVENT_DTYPE), (4, 3))
    assert list(folder.iterdir()) == []  # nothing written into it


def test_fractional_or_bad_stored_sensor_sizes_raise(tmp_path):
    path = tmp_path / "frac.h5"
    with h5py.File(path, "w") as f:
        g = f.create_group("events")
        g["x"], g["y"], g["t"], g["p"] = [0], [0], np.array([1], np.int64), [1]
        g.attrs["width"], g.attrs["height"] = 50.5, 40
    with pytest.raises(ValueError, match=r"frac.h5: the width/height attributes must be the "
                                         r"sensor size .* got \[50.5, 40.0\]"):
        load_events(path)
    path = tmp_path / "frac.npz"
    np.savez(path, x=[0], y=[0], t=[1], p=[1], sensor_size=[50.5, 40])
    with pytest.raises(ValueError, match=r"frac.npz: the array sensor_size must be the sensor "
                                         r"size"):
        load_events(path)
    np.savez(path, x=[0], y=[0], t=[1], p=[1], sensor_size=[50, 40, 3])
    with pytest.raises(ValueError, match=r"got \[50, 40, 3\]"):
        load_events(path)
