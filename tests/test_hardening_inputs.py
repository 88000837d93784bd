"""Readers and metrics against careless and hostile input (issue 26): thresholds outside
[0, 1], sizes beyond what the types hold, and errors that name the file."""

from __future__ import annotations

import math
import os
import tracemalloc

import h5py
import numpy as np
import pytest
import trimesh

from e2vlib.events import EventError, check_sensor_size, make_events
from e2vlib.frames import accumulate
from e2vlib.io import load_events
from e2vlib.metrics import MAX_SURFACE_POINTS, fscore, iou, surface_voxel_fscore
from e2vlib.shapes import load_mesh
from e2vlib.voxels import voxelize

# --- thresholds --------------------------------------------------------------------------------

GRID = np.zeros((32, 32, 32))
GRID[8:24, 8:24, 8:24] = 1.0


@pytest.mark.parametrize("threshold", [2, -0.1, 1.0001, math.nan, math.inf, True, "0.3", None])
def test_thresholds_outside_0_1_or_nan_are_refused(threshold):
    for metric in (iou, fscore, surface_voxel_fscore):
        with pytest.raises(ValueError, match=r"threshold must be a probability in \[0, 1\]"):
            metric(GRID, GRID, threshold=threshold)


def test_the_ends_of_0_1_are_thresholds_with_known_answers():
    pred = GRID * 0.5
    assert iou(pred, GRID, threshold=0.0) == 1.0 * 16 ** 3 / 32 ** 3  # everything predicted
    assert iou(pred, GRID, threshold=0.5) == 1.0
    assert iou(GRID, GRID, threshold=1.0) == 1.0
    assert iou(pred, GRID, threshold=1.0) == 0.0  # nothing reaches 1
    assert iou(pred, GRID, threshold=np.float32(0.5)) == 1.0


def test_fscore_points_are_bounded():
    with pytest.raises(ValueError, match=f"at most {MAX_SURFACE_POINTS}"):
        fscore(GRID, GRID, n_points=10 ** 12)


# --- sizes beyond the types ----------------------------------------------------------------------


def test_a_text_header_beyond_uint16_is_refused(tmp_path):
    path = tmp_path / "big.txt"
    path.write_text("1000000000 1000000000\n0.1 1 1 1\n")
    with pytest.raises(ValueError, match=r"big.txt, line 1: .*got '1000000000 1000000000'; "
                                         r"events store x and y as uint16, so a side is at "
                                         r"most 65536 px"):
        load_events(path)
    path.write_text("65536 1\n0.1 65535 0 1\n")  # the largest sensor uint16 can address
    events, sensor_size = load_events(path)
    assert sensor_size == (65536, 1) and events["x"].tolist() == [65535]


def test_sensor_sizes_beyond_uint16_are_refused_everywhere(tmp_path):
    with pytest.raises(EventError, match="each side is at most 65536 px"):
        check_sensor_size((65537, 10))
    path = tmp_path / "big.npz"
    np.savez(path, x=np.zeros(1, np.uint16), y=np.zeros(1, np.uint16), t=np.zeros(1, np.int64),
             p=np.ones(1, np.int8), sensor_size=np.array([100000, 10]))
    with pytest.raises(ValueError, match=r"big.npz: the array sensor_size must be .* at most "
                                         r"65536 \(x and y are uint16\), got \[100000, 10\]"):
        load_events(path)


def test_accumulate_refuses_stacks_over_its_fixed_cap():
    one = make_events([0], [0], [0], [1])
    # one event on a 65535^2 sensor, 3 frames: 12 GiB of frames, more than 8 GiB
    with pytest.raises(EventError, match=r"3 frames of 4294836225 values would take 12.00 GiB "
                                         r"\(limit 8.00 GiB: frames.MAX_FRAMES_BYTES\)"):
        accumulate(one, (65535, 65535), n_frames=3)
    assert accumulate(one, (64, 64), n_frames=2).shape == (2, 64, 64)  # small stacks still work


def test_accumulate_fast_caps_memory_at_half_of_what_is_available(monkeypatch):
    frames_numba = pytest.importorskip("e2vlib.scale.frames_numba", reason="numba is missing")
    one = make_events([0], [0], [0], [1])
    monkeypatch.setattr(frames_numba, "available_memory", lambda: 2 * 2**30)
    assert frames_numba.frames_memory_limit() == (2**30,
                                                  "half the 2.0 GiB of memory available now")
    # one event on a 65535^2 sensor: 4 GiB of frames, more than half of 2 GiB
    with pytest.raises(EventError, match=r"1 frames of 4294836225 values would take 4.00 GiB "
                                         r"\(limit 1.00 GiB: half the 2.0 GiB of memory "
                                         r"available now\)"):
        frames_numba.accumulate_fast(one, (65535, 65535), n_frames=1)
    assert frames_numba.accumulate_fast(one, (64, 64), n_frames=2).shape == (2, 64, 64)
    # with plenty of memory free, the fixed 8 GiB cap says what it is
    monkeypatch.setattr(frames_numba, "available_memory", lambda: 64 * 2**30)
    assert frames_numba.frames_memory_limit() == (8 * 2**30, "frames.MAX_FRAMES_BYTES")
    with pytest.raises(EventError, match=r"limit 8.00 GiB: frames.MAX_FRAMES_BYTES"):
        frames_numba.accumulate_fast(one, (65535, 65535), n_frames=3)


@pytest.mark.parametrize("mode", ["count", "polarity"])
def test_accumulate_counts_within_the_stack_it_returns(mode):
    # counting with np.bincount took three times the stack (its int64 counts, then their
    # int32 copy); np.unique's counts need memory per event, not per value
    events = make_events([0, 5, 5, 5], [0, 7, 7, 7], [0, 10, 20, 1500], [1, -1, 1, 1])
    expected = np.zeros((4, 1024, 1024) if mode == "count" else (4, 2, 1024, 1024), np.int32)
    if mode == "count":
        expected[0, 0, 0], expected[0, 7, 5], expected[1, 7, 5] = 1, 2, 1
    else:  # channel 0 OFF, 1 ON
        expected[0, 1, 0, 0] = expected[0, 0, 7, 5] = expected[0, 1, 7, 5] = 1
        expected[1, 1, 7, 5] = 1
    tracemalloc.start()
    try:
        stack = accumulate(events, (1024, 1024), dt_us=1000, n_frames=4, mode=mode)
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert stack.dtype == np.int32 and peak < 1.1 * stack.nbytes
    np.testing.assert_array_equal(stack, expected)


def test_available_memory_is_read_on_this_machine():
    frames_numba = pytest.importorskip("e2vlib.scale.frames_numba", reason="numba is missing")
    assert frames_numba.available_memory() > 2**20


# --- errors that name the file ------------------------------------------------------------------


def test_a_random_bytes_npz_is_named_and_not_called_pickled(tmp_path):
    path = tmp_path / "noise.npz"
    path.write_bytes(np.random.default_rng(0).bytes(500))
    with pytest.raises(ValueError) as info:
        load_events(path)
    message = str(info.value)
    assert message.startswith(f"{path}: not an .npz event file (neither a zip of x, y, t, p")
    assert "allow_pickle" not in message and "save_events" in message


def test_an_hdf5_time_unit_error_names_the_file(tmp_path):
    path = tmp_path / "unit.h5"
    with h5py.File(path, "w") as f:
        group = f.create_group("events")
        for name in "xytp":
            group[name] = np.array([1, 2])
        group.attrs["t_unit"] = "fortnights"
    with pytest.raises(ValueError, match=rf"{path}: unknown t_unit 'fortnights'; expected one "
                                         r"of \['s', 'ms', 'us', 'ns'\] \(the t_unit "
                                         r"attribute"):
        load_events(path)


def test_voxelize_refuses_face_indices_outside_the_vertices():
    mesh = trimesh.Trimesh(np.array([[0, 0, 0], [0.1, 0, 0], [0, 0.1, 0.0]]),
                           np.array([[0, 1, 5]]), process=False)
    with pytest.raises(ValueError, match=r"mesh faces index vertices 0..5 but the mesh has 3 "
                                         r"\(0..2\)"):
        voxelize(mesh)


@pytest.mark.parametrize("bad", ["nan", "inf"])
def test_an_obj_with_a_non_finite_vertex_says_so(tmp_path, bad):
    path = tmp_path / "tetra.obj"
    path.write_text(f"v 0 0 0\nv 1 0 0\nv {bad} 1 0\nv 0 0 1\n"
                    "f 1 2 3\nf 1 2 4\nf 1 3 4\nf 2 3 4\n")
    with pytest.raises(ValueError, match=rf"{path}: 1 of 4 vertices have NaN or infinite "
                                         r"coordinates"):
        load_mesh(path)
    path.write_text(path.read_text().replace(bad, "0"))
    assert len(load_mesh(path).faces) == 4  # the fixed file loads whole


def test_no_pickles_and_weights_only_loads_in_the_library():
    root = os.path.join(os.path.dirname(__file__), "..", "e2vlib")
    for folder, _, names in os.walk(root):
        for name in names:
            if name.endswith(".py"):
                text = open(os.path.join(folder, name)).read()
                assert "allow_pickle=True" not in text, name
                for line in text.splitlines():
                    if "torch.load(" in line:
                        assert "weights_only=True" in line, (name, line)
