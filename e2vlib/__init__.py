"""e2vlib: the thin, tested helper library behind the e2v notebooks.

One module (or package) per step of the E2V pipeline (Chen et al., ICVR 2023), data flowing
one way; a module imports only modules of its own stage or of earlier ones::

    shapes -> voxels, orbit -> render -> simulate -> io -> frames -> inputs -> data
    -> model -> train -> geometry, viz -> experiments, explore, figures, reports
    -> reconstruct, the command line (__main__)

``paper`` (the paper's facts and our documented choices), ``files`` (crash-safe writing),
``events`` (the event array everything passes along), ``metrics`` (IoU and F-score of
plain arrays) and ``losses`` are shared by every stage. ``tests/test_layout.py`` checks the
stage order, that no import cycle exists, that no module exceeds 600 lines, and that the map
below is current.

Importing the package does no work: no seeds, no downloads, no plotting backend changes.

Module map (``python tools/module_map.py --write``; 19,991 lines)::

    __main__.py             78  Command line
    _headless.py           106  VTK's environment for headless machines and notebooks, set ...
    cli/                  1151  The command line's parts: python -m e2vlib (__main__) runs them
      checks.py            274  Checks of command-line values before any work starts
      data_commands.py     159  The dataset commands
      errors.py            124  How the command line fails
      model_commands.py    259  The model commands
      parser.py            212  The command line's parser
      study_commands.py     87  The study command
    data/                 2317  Datasets
      build.py             204  Building a dataset
      checks.py            280  A dataset folder is untrusted input
      commands.py           84  The python -m e2vlib make-data command lines that build (or ...
      config.py            215  Build settings
      dataset.py           281  Reading a dataset
      grey.py              185  Grey video at the event frames' times (make-data --grey-video)
      manifest.py          135  ROOT/manifest.csv
      plan.py              120  Sample planning
      samples.py           208  One sample
      shards.py            288  Sharded dataset builds
      synthevox3d.py       117  The authors' released SynthEVox3D layout
    dataset_checks.py       39  Old home of checks (a dataset folder is untrusted input) ...
    events.py              325  Event streams as numpy structured arrays, and their validation
    experiments/          1923  Experiments
      caches.py             91  The dataset folders the studies read besides data_small, and ...
      geometry_study.py    235  The geometry study
      loader.py            258  A study protocol's splits as model inputs, kept in memory ...
      provenance.py         58  Where a record was made
      real_study.py        298  Scoring on real meshes
      records.py           172  Recorded study results, read the same way by every lesson
      runner.py            260  Running studies
      shipping.py           84  Ship one recorded run's model
      studies.py           220  The studies
      summary.py           120  A study's results as numbers
    explore.py             246  A dataset explorer
    figures.py             115  The README's pictures, rendered from a dataset and a trained ...
    files.py                97  Crash-safe file writing
    frames.py              559  Event representations
    frames_fast.py         280  Compiled (numba) kernels behind accumulate's default fast path
    geometry.py            393  Geometry baselines without learning
    geometry_study.py       12  The geometry study now lives in geometry_study; this name ...
    inputs/                555  Model inputs
      representations.py   356  Model inputs from events
      tensors.py           148  A split held in memory
    io.py                  536  Read and write event files, converting every foreign ...
    losses.py              208  Training losses on occupancy logits
    metrics.py             406  Reconstruction metrics
    model/                1856  The E2V model
      checkpoint.py        351  E2V checkpoint files
      config.py            306  E2V's configuration
      decoder.py           170  E2V's bridge and decoder
      encoders.py          273  E2V's encoders
      integrity.py         150  Is a checkpoint intact
      networks.py          292  The E2V network
      summary.py           181  Size and memory of an E2V
    orbit.py               423  The camera orbit's clock and geometry, numpy only
    paper.py               279  The paper's facts as named constants, and our documented ...
    real_meshes/          1186  Real third-party meshes of the paper's categories, from ...
      ac3d.py              127  A small reader of AC3D (.ac) models, the format of Debian's ...
      build.py             155  Building the real-mesh test set
      catalogue.py         389  Debian's Sweet Home 3D furniture libraries
      mapping.py           212  The reviewed table that maps catalogue entries to the ...
      meshes.py            175  One catalogue entry's model as a trimesh.Trimesh in the ...
    real_study.py           21  The real-mesh study now lives in real_study; this name stays ...
    reconstruct.py         232  Reconstruct one object with a trained checkpoint, from a ...
    render.py              398  Render the paper's spiral camera orbit around an object into ...
    reports.py             101  Recorded results, read the same way by every lesson
    shapes/               2774  Objects to reconstruct
      builders.py          127  The category -> builder table, make_shape (the procedural ...
      cabinets.py          282  Procedural cabinets in five sub-types (CABINET_KINDS), the ...
      devices.py           163  Procedural category builder: the rifle
      displays.py          291  Procedural displays in five sub-types (DISPLAY_KINDS), the ...
      furniture.py         573  Procedural category builders
      meshes.py             97  Meshes in and out of the project's frame
      parts.py              34  Helpers every category builder shares
      primitives.py        126  Mesh primitives the procedural objects are built from
      shapenet.py           73  Reading a ShapeNetCore folder
      speakers.py          285  Procedural loudspeakers in six sub-types (SPEAKER_KINDS) ...
      telephones.py        277  Procedural telephones in five sub-types (TELEPHONE_KINDS) ...
      vehicles.py          394  Procedural category builders
    shards.py                8  Old home of shards (joining sharded builds); its names live ...
    simulate.py            586  Turn a video into events with the ESIM model of an event camera
    train/                1010  Training and evaluation of E2V
      devices.py           126  Where and how fast training runs
      evaluation.py        158  Predictions and the Pix2Vox evaluation protocol
      loop.py              421  The training loop, fit, and what resuming it checks
      recipes.py           212  Training recipes (optimizer settings and epochs) and their ...
    viz/                  1331  Pictures of events, frames, voxels and meshes
      animation.py          70  Matplotlib animations of frame stacks, shown as ...
      export.py            139  A predicted grid as files other tools read
      plots.py             256  Static matplotlib figures
      recording.py         220  PyVista scenes of how the data is recorded
      scenes.py            338  PyVista scenes of voxels and meshes
      style.py              24  The lessons' colours and default views
      widgets.py           192  Widgets around a matplotlib picture that still shows where ...
    voxels.py              440  Occupancy grids

End of the module map.
"""

__version__ = "0.1.0"
