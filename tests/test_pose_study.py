"""The pose-error study: the exact level is data_small itself; an error moves what is seen,
never the label."""

import json

import numpy as np
import pytest

from e2vlib.data import BuildConfig, load_sample, read_manifest
from e2vlib.experiments import orbit_error as oe
from e2vlib.experiments import pose_study as ps

from .conftest import REPO

DATA = REPO / "data_small"


@pytest.fixture(scope="module")
def row():
    return next(r for r in read_manifest(DATA) if r["id"] == "lamp_0013")


@pytest.fixture(scope="module")
def config():
    return BuildConfig.from_dict(json.loads((DATA / "config.json").read_text()))


def test_a_pose_error_is_a_rotation_by_the_angle_and_a_shrink_by_the_radius():
    t = oe.pose_error(2.0, 0.10, seed=7)
    m = t[:3, :3] * 1.10  # the rotation part
    assert np.allclose(m @ m.T, np.eye(3)) and np.isclose(np.linalg.det(m), 1.0)
    assert np.isclose(np.degrees(np.arccos((np.trace(m) - 1) / 2)), 2.0)
    assert np.allclose(t[:3, 3], 0) and np.allclose(t[3], [0, 0, 0, 1])
    assert np.allclose(oe.pose_error(0, 0, seed=3), np.eye(4))
    assert not np.allclose(oe.pose_error(2, 0, seed=1), oe.pose_error(2, 0, seed=2))  # the axis
    with pytest.raises(ValueError, match="radius_error > -1"):
        oe.pose_error(1.0, -1.0, seed=0)


def test_the_exact_level_is_data_smalls_sample_and_the_geometry_studys_scores(row, config):
    from e2vlib.geometry import score_occupancy

    seen = ps.perturbed_object(row, config, "exact")
    frames, voxels = load_sample(DATA / "samples" / f"{row['id']}.npz")
    assert np.array_equal(seen["frames"], frames) and np.array_equal(seen["label"], voxels)
    recorded = next(r for r in json.loads((REPO / "experiments" / "results" / "geometry.json")
                                          .read_text())["runs"] if r["id"] == row["id"])
    for grid, method in ((seen["hull"], "visual_hull"), (seen["carved"], "events_carving")):
        assert score_occupancy(grid, seen["label"])["iou@0.3"] == pytest.approx(
            recorded["scores"][method]["iou@0.3"], abs=1e-12)


def test_a_wider_orbit_than_assumed_shrinks_the_hull_but_not_the_label(row, config):
    exact = ps.perturbed_object(row, config, "exact")
    wide = ps.perturbed_object(row, config, "radius_10pct")
    assert np.array_equal(wide["label"], exact["label"])
    ratio = (wide["hull"] > 0.5).sum() / (exact["hull"] > 0.5).sum()
    assert 0.6 < ratio < 0.9  # about 1 / 1.1 ** 3 = 0.75 of the volume
    assert not np.array_equal(wide["frames"], exact["frames"])


def test_the_first_rows_of_each_category():
    rows = [{"category": c, "id": i} for i, c in enumerate("aabbba")]
    assert [r["id"] for r in ps.first_per_category(rows, 2)] == [0, 1, 2, 3]
    assert len(ps.first_per_category(rows, None)) == 6


def test_a_bad_checkpoint_argument_fails_like_the_main_command_line(capsys, tmp_path):
    assert ps.main(["--out", str(tmp_path), "--checkpoint", "no-equals-sign"]) == 2
    err = capsys.readouterr().err
    assert err.startswith("error: --checkpoint must look like NAME=PATH") and "\n" == err[-1]
    assert not (tmp_path / "pose.json").exists()


@pytest.fixture
def faked(tmp_path, monkeypatch):
    """The perturbed objects faked (a 16^3 cube in the 32^3 grid, seen as itself), to check the
    bookkeeping: ``(run_pose_study's arguments, the ids of the objects made, in order)``."""
    made = []

    def fake_object(row, config, level):
        made.append(row["id"])
        label = np.zeros((32, 32, 32), dtype=bool)
        label[8:24, 8:24, 8:24] = True
        return {"frames": np.zeros((4, 8, 8), dtype=np.uint8), "label": label, "n_events": 0,
                "hull": label, "carved": np.zeros_like(label)}

    monkeypatch.setattr(ps, "perturbed_object", fake_object)
    return {"out": tmp_path, "data": DATA, "cache": tmp_path / "cache", "levels": ("exact",),
            "limit_per_category": 1, "progress": False}, made


def test_a_rerun_remakes_only_the_frames_that_are_gone_and_keeps_the_learned_scores(
        faked, tmp_path):
    run, made = faked
    path = ps.run_pose_study(**run)
    first = list(made)
    assert len(first) == len(set(first)) == 13  # one test object per category
    results = json.loads(path.read_text())
    results["runs"][0]["scores"]["a_model"] = {"iou@0.3": 0.5}
    path.write_text(json.dumps(results))
    gone = [results["runs"][i]["object"] for i in (0, 5)]
    for object_id in gone:
        (tmp_path / "cache" / "exact" / f"{object_id}.npz").unlink()

    made.clear()
    ps.run_pose_study(**run)
    assert sorted(made) == sorted(gone)  # only the two whose frames were deleted
    again = {r["id"]: r for r in json.loads(path.read_text())["runs"]}
    assert len(again) == 13
    record = again[f"exact/{gone[0]}"]
    assert record["scores"]["a_model"] == {"iou@0.3": 0.5}
    assert record["scores"]["visual_hull"]["iou@0.2"] == pytest.approx(1.0)
    assert all((tmp_path / "cache" / "exact" / f"{o}.npz").exists() for o in gone)


def test_an_added_checkpoint_scores_every_record_once_and_its_command_is_kept(
        faked, monkeypatch):
    import torch

    run, _ = faked
    path = ps.run_pose_study(**run)
    loaded = []
    monkeypatch.setattr("e2vlib.model.load_checkpoint", loaded.append)
    # a model that fills the grid: IoU with the 16^3 cube is 16^3 / 32^3 = 0.125
    monkeypatch.setattr("e2vlib.train.predict", lambda model, x, device: torch.full(
        (len(x), 32, 32, 32), 0.9))
    ps.add_checkpoints(path, {"filler/seed0": "filler.pt"}, run["cache"], progress=False)
    results = json.loads(path.read_text())
    assert loaded == ["filler.pt"] and len(results["runs"]) == 13
    assert all(r["scores"]["filler/seed0"] == {"iou@0.3": 0.125} for r in results["runs"])
    assert ps.level_table(results)["filler"] == {"exact": 0.125}
    assert results["commands"] == [ps.COMMAND,
                                   f"{ps.COMMAND} --checkpoint filler/seed0=filler.pt"]
    ps.add_checkpoints(path, {"filler/seed0": "filler.pt"}, run["cache"], progress=False)
    assert loaded == ["filler.pt"] and json.loads(path.read_text()) == results  # nothing new


# ---------------------------------------------------------------- training under pose noise


def test_orbit_error_draws_stay_in_bounds_and_depend_on_the_object_only():
    draws = [oe.orbit_error_draw(2.0, 0.05, seed) for seed in range(200)]
    angles, radii = np.array(draws).T
    assert angles.min() >= 0 and angles.max() <= 2 and np.abs(radii).max() <= 0.05
    assert radii.min() < -0.03 and radii.max() > 0.03  # both signs: wider and narrower
    assert oe.orbit_error_draw(2.0, 0.05, 5) == draws[5]
    assert oe.orbit_error_draw(0.0, 0.0, 5) == (0.0, 0.0)


def test_labels_through_no_orbit_error_are_the_stored_labels():
    rows = [r for r in read_manifest(DATA) if r["split"] == "train"][::97]
    labels = oe.labels_through_orbit_error(DATA, [r["id"] for r in rows], (0.0, 0.0))
    for row, label in zip(rows, labels, strict=True):
        assert np.array_equal(label, load_sample(DATA / "samples" / f"{row['id']}.npz")[1])


def test_the_frames_of_a_wider_orbit_pair_with_a_larger_label():
    # frames filmed from 1.1x the assumed radius look like an object 1 / 1.1 the size: the
    # true shape behind the stored frames is 1.1x larger. Its longest side already spans the
    # grid and is cut there, so the volume grows about 1.1^2 = 1.21x (the wrong way, 0.83x)
    row = next(r for r in read_manifest(DATA) if r["id"] == "cabinet_0000")
    stored = load_sample(DATA / "samples" / "cabinet_0000.npz")[1]
    wider = oe.label_through_orbit_error("cabinet", int(row["seed"]), 0.0, 0.10)
    turned = oe.label_through_orbit_error("cabinet", int(row["seed"]), 5.0, 0.0)
    assert 1.1 < wider.sum() / stored.sum() < 1.3
    assert 0.9 < turned.sum() / stored.sum() < 1.1 and not np.array_equal(turned, stored)


def test_a_pose_noise_protocol_remakes_train_and_val_labels_only():
    from e2vlib.experiments.loader import load_split
    from e2vlib.experiments.protocol import Protocol

    plain = Protocol(per_category=1, frame_size=32)
    noisy = plain.updated({"pose_noise": [2.0, 0.05]})  # a record's JSON list
    assert noisy.pose_noise == (2.0, 0.05) and noisy.to_dict()["pose_noise"] == [2.0, 0.05]
    assert Protocol.from_dict(noisy.to_dict()) == noisy
    for split in ("train", "val", "test"):
        a, b = load_split(plain, split), load_split(noisy, split)
        assert a.ids == b.ids and np.array_equal(a.frames, b.frames)
        changed = [not np.array_equal(x, y) for x, y in zip(a.voxels, b.voxels, strict=True)]
        assert any(changed) == (split != "test"), split
    with pytest.raises(ValueError, match="pose_noise must be"):
        Protocol(pose_noise=(2.0, -0.05))
    with pytest.raises(ValueError, match="pose_noise must be"):
        Protocol(pose_noise=(2.0,))


def test_level_objects_average_the_seeds_of_the_level_tables_methods():
    results = json.loads((REPO / "experiments" / "results" / "pose.json").read_text())
    table = ps.level_table(results)
    for method in ("visual_hull", "e2v"):
        for level, mean in table[method].items():
            values = ps.level_objects(results, method, level)
            assert len(values) == 78 and np.mean(list(values.values())) == pytest.approx(mean)
    assert ps.level_objects(results, "e2v", "no_such_level") == {}
