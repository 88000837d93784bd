"""Orbit errors: how an object looks to the assumed cameras when the real orbit is off.

Turning every camera by R about the object's centre shows the same images as turning the
object by R⁻¹ under the assumed cameras, and an orbit ``1 + e`` times wider the same as the
object shrunk by ``1 / (1 + e)``. :func:`pose_error` is that transform; the pose study
(:mod:`e2vlib.experiments.pose_study`) tests every method through it, and training under pose
noise (``Protocol.pose_noise``) remakes each training label through a drawn error
(:func:`labels_through_orbit_error`). Nothing here imports the rest of the lab.
"""

from __future__ import annotations

import os
from collections.abc import Sequence

import numpy as np

from e2vlib import paper


def pose_error(angle_deg: float, radius_error: float, seed: int) -> np.ndarray:
    """The ``(4, 4)`` transform that moves an object as an orbit error of ``angle_deg`` (about
    a random axis drawn from ``seed``) and ``radius_error`` looks to the assumed cameras: the
    inverse rotation, then a scale of ``1 / (1 + radius_error)`` about the origin.

    >>> t = pose_error(0.0, 0.25, seed=0)
    >>> np.allclose(t[:3, :3], np.eye(3) / 1.25), t[:3, 3].tolist()
    (True, [0.0, 0.0, 0.0])
    >>> r = pose_error(5.0, 0.0, seed=0)[:3, :3]
    >>> round(float(np.degrees(np.arccos((np.trace(r) - 1) / 2))), 6)  # turned by 5 degrees
    5.0
    """
    from scipy.spatial.transform import Rotation

    if not (np.isfinite(angle_deg) and np.isfinite(radius_error) and radius_error > -1):
        raise ValueError(f"pose error ({angle_deg}, {radius_error}) must be finite with "
                         "radius_error > -1")
    axis = np.random.default_rng(seed).normal(size=3)
    axis /= np.linalg.norm(axis)
    transform = np.eye(4)
    rotation = Rotation.from_rotvec(np.radians(angle_deg) * axis).inv().as_matrix()
    transform[:3, :3] = rotation / (1.0 + radius_error)
    return transform


TRAIN_ERROR_SALT = 20_230
"""Mixed into an object's seed for the orbit error its training label is remade through, so
that error is drawn apart from the object's shape."""


def orbit_error_draw(max_angle_deg: float, max_radius_error: float, seed: int
                     ) -> tuple[float, float]:
    """One object's orbit error for training under pose noise: ``(angle in degrees, uniform
    in [0, max_angle_deg]; relative radius error, uniform in [-max, +max])``, drawn from
    ``seed`` (the object's) alone, so a set is remade the same way every time.

    >>> angle, radius = orbit_error_draw(2.0, 0.05, seed=7)
    >>> 0 <= angle <= 2 and -0.05 <= radius <= 0.05, orbit_error_draw(2.0, 0.05, 7) == (
    ...     angle, radius)
    (True, True)
    """
    rng = np.random.default_rng([int(seed), TRAIN_ERROR_SALT])
    return (float(rng.uniform(0.0, max_angle_deg)),
            float(rng.uniform(-max_radius_error, max_radius_error)))


def label_through_orbit_error(category: str, seed: int, angle_deg: float,
                              radius_error: float) -> np.ndarray:
    """The label (bool ``(32, 32, 32)``) that pairs a procedural object's stored event frames
    with an orbit error of ``(angle_deg, radius_error)``.

    The study's test pairs are (events of the object moved by :func:`pose_error`'s ``T``,
    the object's shape). Stored frames are the events of ``X`` (the normalized mesh) under
    the assumed cameras, so with ``O = T^-1 X`` the same kind of pair is (the stored frames,
    the shape of ``O``): ``X`` moved by the inverse of ``T``, then voxelized as
    :func:`e2vlib.data.mesh_to_sample` does. At ``(0, 0)`` this is the stored label."""
    from e2vlib.shapes import make_shape, normalize_mesh
    from e2vlib.voxels import voxelize

    mesh = normalize_mesh(make_shape(category, int(seed)))
    mesh.apply_transform(np.linalg.inv(pose_error(angle_deg, radius_error, int(seed))))
    return voxelize(mesh, paper.GRID_SIDE).astype(bool)


def labels_through_orbit_error(data: str | os.PathLike, ids: Sequence[str],
                               pose_noise: tuple[float, float], progress: bool = False
                               ) -> np.ndarray:
    """Bool ``(N, 32, 32, 32)``: the labels of the procedural objects ``ids`` of dataset
    ``data``, each remade through its own orbit error (:func:`orbit_error_draw` of
    ``pose_noise`` = ``(max degrees, max relative radius error)``, then
    :func:`label_through_orbit_error`); about 20 ms an object."""
    from tqdm.auto import tqdm

    from e2vlib.data import read_manifest

    rows = {r["id"]: r for r in read_manifest(data)}
    missing = [i for i in ids if i not in rows]
    if missing:
        raise ValueError(f"pose_noise remakes labels from each object's procedural seed, but "
                         f"{data}'s manifest has no row for {missing[:3]}; train with "
                         "pose_noise on a procedural dataset (data_small) only")
    labels = []
    for sid in tqdm(ids, desc="labels through orbit errors", disable=not progress, leave=False):
        row = rows[sid]
        seed = int(row["seed"])
        labels.append(label_through_orbit_error(row["category"], seed,
                                                *orbit_error_draw(*pose_noise, seed)))
    return np.stack(labels) if labels else np.zeros((0,) + (paper.GRID_SIDE,) * 3, bool)
