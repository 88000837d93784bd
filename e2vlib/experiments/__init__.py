"""The lab: studies of the paper's open questions, their records and reports, real meshes.

Everything here sits above core and speed-and-scale and is never imported by them; lessons
09-13 and the command line use it. A *study* is a question (which event representation? how
many frames? which encoder? which loss?) and a set of named *configs*, each a small dict of
what differs from the study's :class:`Protocol`. :func:`run_study` trains and evaluates every
(config, seed) with :func:`e2vlib.scale.training.fit_at_scale` and scores it with
:func:`e2vlib.metrics.score_split`, and appends one record per run to ``OUT/STUDY.json``
(written atomically after every run); runs already recorded are skipped, so an interrupted
study resumes where it stopped. :func:`summarize` turns a results file into mean, standard
deviation and a 95 % interval per config. The public names of the study modules are
importable from here (``from e2vlib.experiments import STUDIES, run_study``):

================================  ===========================================================
``experiments.protocol``          :class:`Protocol`, a study's settings as a frozen dataclass
                                  with what follows from them (epochs, run size, the events
                                  folder), :func:`canonical_protocol` (when two protocols are
                                  one run), :func:`first_per_category`
``experiments.studies``           :class:`Study`, :data:`STUDIES`, :data:`QUICK`,
                                  :data:`THRESHOLDS`, :func:`is_collapsed`
``experiments.caches``            the dataset folders studies read besides data_small and the
                                  commands that build them (:func:`cache_command`, ...)
``experiments.loader``            a protocol's splits as model inputs, cached in memory
                                  (:func:`load_split`, :func:`protocol_data_config`)
``experiments.provenance``        where a record was made (:func:`git_commit`,
                                  :func:`cpu_name`, :func:`package_version`)
``experiments.runner``            one run (:func:`run_one`), a whole study (:func:`run_study`),
                                  reused runs (:func:`find_same_run`), :func:`best_threshold`,
                                  and the one writer of results files: :func:`update_results`
                                  (under a lock: read, merge, atomic rename), read back by
                                  :func:`read_results` and checked by :func:`check_results`
``experiments.summary``           :func:`summarize`, :func:`format_study_table`,
                                  :func:`plot_summary`, :func:`is_real_difference` (the one
                                  rule for a real difference), :func:`compare`
``experiments.reports``           recorded results read as the lessons read them: studies
                                  (:func:`load_results`, :func:`report`, :func:`finding`)
                                  and bench figures (:func:`bench_table`, ...)
``experiments.classroom``         the small study a student runs in lessons 09-13: a mini
                                  dataset (:func:`build_mini_dataset`), two configs x three
                                  seeds (:func:`run_class_study`) scored object by object
                                  on a larger test set (:func:`paired_difference`), one
                                  figure beside the record (:func:`plot_class_study`)
================================  ===========================================================

Imported by their module names (they run as commands, or load much):

================================  ===========================================================
``experiments.geometry_study``    the visual hull and events-only carving against the learned
                                  model, no training (:func:`run_geometry_study`)
``experiments.hybrid_study``      the hybrid study read object by object against the
                                  geometry baselines (paired intervals, per category)
``experiments.pose_study``        every method when the orbit is off by an angle or a radius
                                  error (``python -m e2vlib.experiments.pose_study``)
``experiments.orbit_error``       an orbit error as a move of the object (:func:`pose_error`)
                                  and training labels remade through one
``experiments.real_study``        models and baselines scored on real third-party meshes
                                  (``python -m e2vlib.experiments.real_study``)
``experiments.real_meshes``       the real meshes: catalogue, reviewed mapping, AC3D reader,
                                  the real-mesh test set
``experiments.shipping``          one kept run's model made into a checkpoint for students
                                  (``data_small/checkpoints/e2v_tiny.pt``)
``experiments.reconstruct``       one object reconstructed by a checkpoint, from a mesh or an
                                  event file (``python -m e2vlib reconstruct``)
``experiments.explore``           a dataset explorer for lesson 08
``experiments.build_cache``       datasets built once per machine and copied where a lesson
                                  asks for them (:func:`build_once`, the mini datasets)
``experiments.figures``           the README's pictures (``python -m e2vlib figures``)
================================  ===========================================================

Command line: ``python -m e2vlib experiment STUDY [--configs ...] [--seeds 0 1 2]``.
Introduced in notebooks/09_event_representations_and_time.ipynb.
"""

import lazy_loader

__getattr__, __dir__, __all__ = lazy_loader.attach(
    __name__,
    submod_attrs={
        "classroom": [
            "CLASS_CATEGORIES", "CLASS_EPOCHS", "CLASS_FRAME_SIZE", "CLASS_PER_CATEGORY",
            "CLASS_SEEDS", "CLASS_TEST_PER_CATEGORY", "CLASS_TEST_SEED", "all_occupied_iou",
            "build_mini_dataset", "class_finding", "class_overrides", "class_test_path",
            "class_verdict", "leader", "objects_to_tell", "paired_difference",
            "plot_class_study", "run_class_study", "score_class_study",
        ],
        "caches": [
            "BUILD_WORKERS", "DATA_COMMANDS", "DEFAULT_OUT", "EVENTS_CACHE", "EVENTS_COMMAND",
            "EXTRA_CACHE", "EXTRA_COMMAND", "NOISE_CACHE", "NOISE_COMMANDS", "RENDER_CACHE",
            "RENDER_COMMAND", "SMALL_SETTINGS", "STORAGE_SETTINGS", "cache_command",
        ],
        "loader": ["load_split", "protocol_data_config"],
        "protocol": ["NEUTRAL", "Protocol", "canonical_protocol", "first_per_category"],
        "provenance": ["REPO", "cpu_name", "git_commit", "package_version"],
        "reports": [
            "BENCH_RESULTS", "RESULTS_DIR", "MissingResultsError", "bench_machine",
            "bench_section", "bench_table", "finding", "lesson_minutes", "load_results",
            "minutes_per_run", "recorded_on", "report", "runs_of",
        ],
        "runner": [
            "LOCK_TIMEOUT_S", "OBJECT_KEY", "RUN_KEY", "as_seed", "best_threshold",
            "check_results", "command_line", "find_same_run", "merge_results", "read_results",
            "results_lock", "run_one", "run_study", "update_results",
        ],
        "studies": ["COLLAPSE_IOU", "QUICK", "STUDIES", "THRESHOLDS", "Study", "is_collapsed"],
        "summary": [
            "compare", "format_study_table", "is_real_difference", "plot_summary", "run_key",
            "summarize", "unique_runs",
        ],
    },
)
