"""Datasets: build E2V samples from meshes, store them compactly, and read them back.

One sample is what the paper feeds its network: an object is rendered along the spiral
orbit (120 frames at 240 fps = 0.5 s, rendered ``oversample`` times denser for the
simulator), the video becomes events (ESIM, contrast 0.2), the events become 100 binary
frames of 5 ms, max-pooled down to ``frame_size``; the label is the object's 32^3 voxel
grid. The names a lesson or a user calls are importable from here
(``from e2vlib.data import BuildConfig, build_dataset, E2VDataset``); the size limits and
the builder's helpers are imported from their modules. The code lives in ten modules,
each with one job:

=========================  =================================================================
``data.checks``            a dataset folder is untrusted input: :class:`DatasetError`,
                           :func:`read_config`,
                           :func:`check_id`, :func:`inside`, :data:`SPLITS`, the size
                           limits (:data:`MAX_FRAMES_PER_SAMPLE`, ...)
``data.config``            build settings: :class:`BuildConfig` (ROOT/config.json),
                           :func:`dataset_config`, and a model's frame settings
                           (:func:`frame_settings`, :data:`FRAME_FIELDS`)
``data.commands``          the make-data command lines: :func:`make_data_command`,
                           :func:`build_command`
``data.plan``              which samples a build makes: :class:`SampleSpec`,
                           :func:`plan_samples`, :func:`sample_seed`, :func:`parse_shard`,
                           :func:`raw_event_ids`
``data.grey``              grey video at the event frames' times: :func:`rendered_times_us`,
                           :func:`grey_frame_indices`, :func:`grey_frame_cameras`,
                           :func:`video_to_grey`, :func:`save_grey_video`,
                           :func:`load_grey_video`
``data.samples``           one sample: :func:`mesh_to_sample` (mesh -> voxels, video,
                           events, frames), :class:`Sample`, :func:`save_sample`,
                           :func:`load_sample`
``data.manifest``          ROOT/manifest.csv: :func:`write_manifest`, :func:`read_manifest`,
                           :func:`npz_digest`, :func:`manifest_digests`
``data.build``             :func:`build_dataset` (resumable, sharded),
                           :func:`check_build_folder`, :func:`describe_build`,
                           :func:`run_jobs` (tqdm's process pool, :class:`JobError`)
``data.synthevox3d``       the authors' released layout: :func:`synthevox3d_items`,
                           :func:`load_synthevox3d_scan`, :func:`synthevox3d_time_scale`
``data.dataset``           reading: :class:`E2VDataset` (a PyTorch ``Dataset``),
                           :func:`verify_dataset`, :class:`Verification`
=========================  =================================================================

``checks`` imports only ``e2vlib.paper`` and ``frames``; the others import the modules above
them in this table (and ``e2vlib.inputs``, ``frames``, ``io``, ``events``, ``files``,
``paper``; ``render``, ``simulate``, ``noise``, ``shapes`` and ``voxels`` lazily); none
imports this package's ``__init__``. Events become frames in :mod:`e2vlib.inputs`
(:func:`e2vlib.inputs.orbit_input` for the builder and SynthEVox3D scans). Joining shards
built in separate folders is speed and scale: :func:`e2vlib.scale.shards.merge_datasets`
(``python -m e2vlib merge-data``).

Layout written by :func:`build_dataset` (``data_small/`` is one)::

    ROOT/manifest.csv           id, category, split, seed, n_events, sha256 (one row per sample)
    ROOT/config.json            the builder's settings (resolution, frame size, ...)
    ROOT/samples/<id>.npz       frames (bit-packed), voxels (bit-packed), n_events
    ROOT/events/<id>.npz        raw events of a few samples (e2vlib.io format)
    ROOT/grey/<id>.npz          grey video at the event frames' times (``--grey-video`` only)
    ROOT/shards/<i>-of-<n>.json which shards ran here (``--shard i/n`` builds only)

``sha256`` is the digest of each sample file's arrays (:func:`npz_digest`); older manifests
without it read as before. :class:`E2VDataset` reads that
layout and the authors' released SynthEVox3D layout.

Introduced in notebooks/04_building_the_dataset.ipynb.
"""

import lazy_loader

__getattr__, __dir__, __all__ = lazy_loader.attach(
    __name__,
    submod_attrs={
        "build": ["build_dataset", "check_build_folder", "describe_build", "JobError", "run_jobs"],
        "checks": ["SPLITS", "DatasetError", "read_config"],
        "commands": ["build_command", "make_data_command"],
        "config": ["BuildConfig"],
        "dataset": ["E2VDataset", "Verification", "verify_dataset"],
        "grey": ["grey_frame_cameras", "grey_frame_indices", "load_grey_video", "video_to_grey"],
        "manifest": ["npz_digest", "read_manifest", "write_manifest"],
        "plan": ["parse_shard", "plan_samples", "sample_seed", "SampleSpec"],
        "samples": ["load_sample", "mesh_to_sample", "Sample", "save_sample"],
        "synthevox3d": [
            "SYNTHEVOX3D_SENSOR", "load_synthevox3d_scan", "synthevox3d_items",
            "synthevox3d_time_scale",
        ],
    },
)
