"""The real_objects study and the real objects that ship.

The summary and the paired comparison have hand-computed answers. The study runs end to end
(``slow``: about two minutes) in quick mode on the shipped real objects
(``data_small/real_objects``, one object per category and split, 32 px, one epoch a run)
with a box standing in for every test object's mesh, so no Debian package is needed. The
shipped folder holds only CC0 / CC-BY rows with their credits, and rebuilds byte for byte
from its own samples.
"""

import csv
import json
import shutil
import subprocess

import numpy as np
import pytest
import torch
import trimesh

from e2vlib.data import E2VDataset
from e2vlib.data.manifest import MANIFEST_FIELDS, npz_digest
from e2vlib.experiments.real_objects import catalogue as cat
from e2vlib.experiments.real_objects import ship, study
from e2vlib.inputs import TensorSet

from .conftest import REPO

SHIPPED = REPO / "data_small" / "real_objects"


def results_of(per_object: dict[str, list[list[float]]], hull: list[float],
               categories: list[str]) -> dict:
    """A results dict: ``per_object[config]`` holds one list of IoUs per seed."""
    runs = [{"config": name, "seed": seed, "n_train": 10,
             "per_object": {"iou@val_threshold": values}}
            for name, seeds in per_object.items() for seed, values in enumerate(seeds)]
    return {"runs": runs, "test_categories": categories, "test_ids": list("abcd"),
            "baselines": {"visual_hull": {"per_object": {"iou@val_threshold": hull}}}}


def test_summary_means_over_seeds_and_intervals_over_seeds_or_objects():
    r = results_of({"real": [[0.2, 0.4, 0.6, 0.8], [0.4, 0.6, 0.8, 1.0]]},
                   hull=[0.5, 0.5, 0.5, 0.5], categories=["chair", "chair", "lamp", "lamp"])
    s = study.summarize_real_objects(r)
    assert s["real"]["n_seeds"] == 2
    assert s["real"]["mean"] == pytest.approx(0.6)  # seeds' means 0.5 and 0.7
    lo, hi = s["real"]["ci95"]  # t(1) = 12.706, standard error 0.1
    assert (lo, hi) == pytest.approx((0.6 - 1.2706, 0.6 + 1.2706), abs=1e-3)
    assert s["real"]["per_category"] == pytest.approx({"chair": 0.4, "lamp": 0.8})
    assert s["visual_hull"]["n_seeds"] is None and s["visual_hull"]["mean"] == 0.5
    assert s["visual_hull"]["ci95"] == pytest.approx((0.5, 0.5))  # no spread over objects


def test_paired_comparison_uses_each_objects_mean_over_seeds():
    r = results_of({"real": [[0.2, 0.4, 0.6, 0.8], [0.4, 0.6, 0.8, 1.0]]},
                   hull=[0.5, 0.5, 0.5, 0.5], categories=["chair"] * 4)
    d = study.paired_with(r, "real")  # differences -0.2, 0, 0.2, 0.4
    assert d["n"] == 4 and d["wins"] == 2
    assert d["mean"] == pytest.approx(0.1)
    assert d["ci95"][0] < 0 < d["ci95"][1]  # four objects cannot settle it
    with pytest.raises(ValueError, match="no runs of 'mixed'"):
        study.paired_with(r, "mixed")


def test_join_keeps_every_sample_in_order():
    a = TensorSet(torch.zeros(2, 1, 2, 2), torch.zeros(2, 32, 32, 32, dtype=torch.bool),
                  ["chair", "lamp"], ["c", "l"], {"n": 1})
    b = TensorSet(torch.ones(1, 1, 2, 2), torch.ones(1, 32, 32, 32, dtype=torch.bool),
                  ["sofa"], ["s"])
    j = study.join([a, b])
    assert j.ids == ["c", "l", "s"] and j.categories == ["chair", "lamp", "sofa"]
    assert j.frames[2].sum() == 4 and j.voxels[:2].sum() == 0 and j.config == {"n": 1}


def test_the_learning_curve_keeps_the_full_fine_tunes_steps():
    full = study.CONFIGS["fine_tuned"]
    for k in (8, 4, 2):
        c = study.CONFIGS[f"fine_tuned_1/{k}"]
        assert c.start == "procedural" and c.real_fraction * c.epochs == full.epochs


@pytest.fixture(scope="module")
def quick_study(tmp_path_factory):
    """The study in quick mode on the shipped objects, every config, seed 0."""
    out = tmp_path_factory.mktemp("study")
    box = trimesh.creation.box(extents=(0.5, 0.5, 0.5))
    asked = []

    def load_mesh(sid):
        asked.append(sid)
        return box

    path = study.run_real_objects(list(study.CONFIGS), (0,), out / "results", SHIPPED,
                                  out / "checkpoints", quick=True, load_mesh=load_mesh,
                                  progress=False)
    return out, json.loads(path.read_text()), asked


@pytest.mark.slow
def test_quick_study_records_every_config_and_the_baselines(quick_study):
    out, results, asked = quick_study
    test = E2VDataset(SHIPPED, "test")
    wanted = [test.ids[i] for i in range(len(test))]
    first = {}
    for sid, c in zip(test.ids, test.categories, strict=True):
        first.setdefault(c, sid)
    assert results["test_ids"] == list(first.values()) == asked  # one per category
    assert set(wanted) >= set(asked)
    assert sorted(r["config"] for r in results["runs"]) == sorted(study.CONFIGS)
    n = len(results["test_ids"])
    for run in results["runs"]:
        assert len(run["per_object"]["iou@0.3"]) == n
        assert 0 <= run["metrics"]["procedural:iou@0.3"] <= 1
        assert (out / "checkpoints" / "quick").joinpath(
            run["checkpoint"].rsplit("/", 1)[-1]).exists()
    runs = {r["config"]: r for r in results["runs"]}
    assert runs["fine_tuned"]["start"].endswith("quick/procedural_seed0.pt")
    assert runs["real"]["start"] is None
    assert runs["mixed"]["n_train"] == runs["procedural"]["n_train"] + runs["real"]["n_train"]
    # the hybrid trains the lifted model on the same objects: more weights (the lift stem)
    assert runs["hybrid_mixed"]["n_train"] == runs["mixed"]["n_train"]
    assert runs["hybrid_mixed"]["n_parameters"] > runs["mixed"]["n_parameters"]
    # a hull of a box scored against each object's own label: IoU within [0, 1], all recorded
    hull = results["baselines"]["visual_hull"]["per_object"]["iou@0.3"]
    assert len(hull) == n and all(0 <= v <= 1 for v in hull)
    assert "visual_hull" in study.format_real_objects_table(results)


@pytest.mark.slow
def test_quick_study_resumes_without_training_again(quick_study, monkeypatch):
    out, results, _ = quick_study

    def refuse(*args, **kwargs):
        raise AssertionError("a recorded run was trained again")

    monkeypatch.setattr(study, "run_config", refuse)
    path = study.run_real_objects(list(study.CONFIGS), (0,), out / "results", SHIPPED,
                                  out / "checkpoints", quick=True, load_mesh=refuse,
                                  progress=False)
    assert len(json.loads(path.read_text())["runs"]) == len(results["runs"])


def test_a_fine_tune_without_its_start_is_refused(tmp_path):
    with pytest.raises(FileNotFoundError, match="run config 'procedural' seed 3 first"):
        study.start_checkpoint(study.CONFIGS["fine_tuned"], 3, tmp_path, quick=False)
    assert study.start_checkpoint(study.CONFIGS["fine_tuned"], 0, tmp_path, quick=False) == (
        REPO / "data_small" / "checkpoints" / "e2v_tiny.pt").relative_to(REPO)
    assert study.start_checkpoint(study.CONFIGS["real"], 0, tmp_path, quick=False) is None


def test_unknown_configs_and_a_missing_dataset_are_named(tmp_path):
    with pytest.raises(ValueError, match="unknown configs"):
        study.run_real_objects(["hull"], (0,), tmp_path, SHIPPED)
    with pytest.raises(FileNotFoundError, match="make real-data"):
        study.run_real_objects(["real"], (0,), tmp_path, tmp_path / "nothing")


# ------------------------------------------------------------------------ what ships


def test_only_cc0_and_cc_by_objects_ship_each_credited():
    rows = {r.id: r for r in cat.read_catalogue()}
    with open(SHIPPED / "manifest.csv", newline="") as f:
        manifest = list(csv.DictReader(f))
    ids = [m["id"] for m in manifest]
    assert ids and all(rows[i].licence in ship.SHIPPABLE for i in ids)
    assert sorted(ids) == sorted(r.id for r in ship.shippable_rows())
    assert all(m["split"] == rows[m["id"]].split for m in manifest)
    credits = (SHIPPED / "ATTRIBUTION.md").read_text()
    for i in ids:
        line = next(x for x in credits.splitlines() if x.startswith(f"| {i} |"))
        assert rows[i].licence in line and line.count("|") == 7
    tracked = subprocess.run(["git", "ls-files", "data_small/real_objects"], cwd=REPO,
                             capture_output=True, text=True, check=True).stdout.split()
    samples = {t.rsplit("/", 1)[-1][:-4] for t in tracked if t.endswith(".npz")}
    assert samples <= set(ids)  # nothing else under the folder is a sample


def test_every_shipped_sample_matches_its_digest():
    with open(SHIPPED / "manifest.csv", newline="") as f:
        for m in csv.DictReader(f):
            digest = npz_digest(SHIPPED / "samples" / f"{m['id']}.npz")
            assert digest == m["sha256"], m["id"]


def test_the_shipped_folder_rebuilds_identically_from_its_samples(tmp_path):
    data = tmp_path / "data"
    shutil.copytree(SHIPPED / "samples", data / "samples")
    shutil.copy(SHIPPED / "manifest.csv", data / "manifest.csv")
    shutil.copy(SHIPPED / "config.json", data / "config.json")
    counts = ship.ship_samples(data, tmp_path / "out")
    assert counts == {s: len(E2VDataset(SHIPPED, s)) for s in ("train", "val", "test")}
    for name in ("manifest.csv", "config.json", "ATTRIBUTION.md"):
        assert (tmp_path / "out" / name).read_bytes() == (SHIPPED / name).read_bytes(), name


def test_a_row_that_is_not_built_is_refused(tmp_path):
    (tmp_path / "data").mkdir()
    (tmp_path / "data" / "manifest.csv").write_text(",".join(MANIFEST_FIELDS) + "\n")
    with pytest.raises(ValueError, match="not built .* run `make real-data` first"):
        ship.ship_samples(tmp_path / "data", tmp_path / "out")
    assert not (tmp_path / "out").exists()  # nothing written before the refusal
    assert np.all([r.licence in ship.SHIPPABLE for r in ship.shippable_rows()])


def test_no_tracked_file_is_named_after_a_gpl_or_cc_by_sa_object():
    """Samples, meshes, grids and weights are named by the row id: none of a row that may
    not ship is tracked by git."""
    closed = {r.id for r in cat.read_catalogue(kept_only=False)} - {
        r.id for r in ship.shippable_rows(cat.read_catalogue(kept_only=False))}
    tracked = subprocess.run(["git", "ls-files"], cwd=REPO, capture_output=True, text=True,
                             check=True).stdout.split()
    named = [t for t in tracked if t.rsplit("/", 1)[-1].split(".")[0] in closed]
    assert closed and named == []
