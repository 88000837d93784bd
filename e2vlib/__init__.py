"""e2vlib: the thin, tested helper library behind the e2v notebooks.

Imports run downward only, through these bands, lowest first:

- **objects**, ``shapes/``: the procedural objects to reconstruct (content, no pipeline
  step); they import only ``paper`` and ``files``.
- **core**, the other top-level modules and packages: one per step of the E2V pipeline (Chen
  et al., ICVR 2023), what lessons 00-08 teach, data flowing one way::

      (shapes ->) voxels, orbit -> render -> simulate -> noise -> io -> frames -> inputs
      -> data -> model -> train -> geometry (-> viz)

  ``paper`` (the paper's facts and our documented choices), ``files`` (crash-safe writing),
  ``events`` (the event array everything passes along), ``metrics`` (IoU and F-score of
  plain arrays) and ``losses`` are shared by every step. A function a lesson opens reads top
  to bottom in one sitting.
- **pictures**, ``viz/``: 2-D and 3-D views of what core makes; core never imports them.
- **speed and scale**, ``scale/``: opt-in modules that give core's answers faster or larger
  (compiled frames, a plotter cache, resumable and data-parallel training, sharded builds).
- **lab**, ``experiments/``: the studies, their records and reports, real meshes, the
  explorer, the README's figures, reconstruction and shipping a model.

The command line (``cli/``, ``python -m e2vlib``) sits on all three. ``.importlinter`` states
the bands and core's order as contracts that ``make test`` checks (``lint-imports``);
``tests/test_layout.py`` checks that every module has its place, that importing a constant
loads no torch or VTK, and that the map below is current.

Importing the package does no work: no seeds, no downloads, no plotting backend changes.

Module map (``python tools/module_map.py --write``; 25,939 lines)::

    lines per band: objects 3,026 · core 10,426 · pictures 1,302 · speed and scale 1,171 ·
    lab 8,801 · command line 1,213

    shapes/               3026  Objects to reconstruct
      builders.py          128  The category -> builder table, make_shape (the procedural ...
      cabinets.py          324  Procedural cabinets in five sub-types (CABINET_KINDS), the ...
      devices.py           165  Procedural category builder: the rifle
      displays.py          307  Procedural displays in five sub-types (DISPLAY_KINDS), the ...
      furniture.py         507  Procedural category builders
      lamps.py             117  Procedural category builder
      meshes.py            199  Meshes in and out of the project's frame
      parts.py              34  Helpers every category builder shares
      primitives.py        126  Mesh primitives the procedural objects are built from
      shapenet.py           73  Reading a ShapeNetCore folder
      speakers.py          283  Procedural loudspeakers in six sub-types (SPEAKER_KINDS) ...
      telephones.py        307  Procedural telephones in five sub-types (TELEPHONE_KINDS) ...
      vehicles.py          409  Procedural category builders
    _headless.py           128  VTK's environment for headless machines and notebooks, set ...
    data/                 1994  Datasets
      build.py             254  Building a dataset
      checks.py            202  A dataset folder is untrusted input
      commands.py           84  The python -m e2vlib make-data command lines that build (or ...
      config.py            271  Build settings
      dataset.py           281  Reading a dataset
      grey.py              167  Grey video at the event frames' times (make-data --grey-video)
      manifest.py          198  ROOT/manifest.csv
      plan.py              120  Sample planning
      samples.py           214  One sample
      synthevox3d.py       117  The authors' released SynthEVox3D layout
    events.py              325  Event streams as numpy structured arrays, and their validation
    files.py               200  Crash-safe file writing
    frames.py              383  Event representations
    geometry.py            495  Geometry baselines without learning
    inputs/                473  Model inputs
      representations.py   286  Model inputs from events
      tensors.py           148  A split held in memory
    io.py                  635  Read and write event files, converting every foreign ...
    losses.py              210  Training losses on occupancy logits
    metrics.py             406  Reconstruction metrics
    model/                2010  The E2V model
      checkpoint.py        384  E2V checkpoint files
      config.py            318  E2V's configuration
      decoder.py           170  E2V's bridge and decoder
      encoders.py          274  E2V's encoders
      integrity.py         235  Is a checkpoint intact
      lifting.py            99  The event frames lifted into the grid inside a network
      networks.py          270  The E2V network
      summary.py           182  Size and memory of an E2V
    noise.py               215  Sensor noise of a DVS pixel, added to the events of simulate
    orbit.py               444  The camera orbit's clock and geometry, numpy only
    paper.py               291  The paper's facts as named constants, and our documented ...
    render.py              260  Render the paper's spiral camera orbit around an object into ...
    simulate.py            446  Turn a video into events with the ESIM model of an event camera
    train/                 885  Training and evaluation of E2V
      devices.py            36  Where training runs: resolve_device picks the device
      evaluation.py        176  Predictions and the Pix2Vox evaluation protocol
      loop.py              409  The training loop, fit, and the pieces it is made of
      recipes.py           213  Training recipes (optimizer settings and epochs) and their ...
    voxels.py              472  Occupancy grids
    viz/                  1302  Pictures of events, frames, voxels and meshes
      animation.py          70  Matplotlib animations of frame stacks, shown as ...
      export.py            139  A predicted grid as files other tools read
      plots.py             256  Static matplotlib figures
      recording.py         213  PyVista scenes of how the data is recorded
      scenes.py            338  PyVista scenes of voxels and meshes
      style.py              24  The lessons' colours and default views
      widgets.py           192  Widgets around a matplotlib picture that still shows where ...
    scale/                1171  Speed and scale
      frames_numba.py      358  Frames from events with compiled (numba) kernels
      options.py             7  The choices of fit_at_scale's options, importable without ...
      render_cache.py      124  Off-screen plotters kept for reuse between render_orbit calls
      shards.py            288  Sharded dataset builds
      training.py          375  Training at scale
    experiments/          8801  The lab
      build_cache.py        95  Datasets built once per machine and copied where a lesson ...
      caches.py             91  The dataset folders the studies read besides data_small, and ...
      classroom.py         339  A study a student runs inside a lesson
      errors.py            129  How a command fails
      explore.py           246  A dataset explorer
      figures.py           116  The README's pictures, rendered from a dataset and a trained ...
      geometry_study.py    287  The geometry study
      hybrid_study.py      127  The hybrid study read object by object
      loader.py            191  A study protocol's splits as model inputs, kept in memory ...
      orbit_error.py       108  Orbit errors
      pose_study.py        302  The pose study
      protocol.py          272  A study's protocol
      provenance.py         58  Where a record was made
      real_meshes/        1483  Real third-party meshes of the paper's categories, from ...
        ac3d.py            224  A small reader of AC3D (.ac) models, the format of Debian's ...
        build.py           243  Building the real-mesh test set
        catalogue.py       497  Debian's Sweet Home 3D furniture libraries
        mapping.py         266  The reviewed table that maps catalogue entries to the ...
        meshes.py          185  One catalogue entry's model as a trimesh.Trimesh in the ...
      real_objects/       2829  Real objects of the paper's categories from Debian packages
        __main__.py        177  The recorded commands that build the real-object catalogue ...
        build.py           296  Joins the candidates, the review, the duplicates and the ...
        catalogue.py       216  The committed catalogue of real objects and its checker
        labels.py          206  Solid 32^3 voxel labels for open, many-part meshes
        look.py            142  Looking at the candidates
        readers.py         335  Readers of the real objects' formats, each giving one mesh ...
        samples.py         388  The real objects as samples a model trains on
        ship.py            177  The real objects a lesson may ship
        sources.py         307  The Debian packages real objects come from
        study.py           550  The real_objects study
      real_study.py        421  Scoring on real meshes
      reconstruct.py       327  Reconstruct one object with a trained checkpoint, from a ...
      reports.py           240  Recorded results, read the same way by every lesson
      runner.py            583  Running studies
      shipping.py           94  Ship one recorded run's model
      studies.py           186  The studies
      summary.py           167  A study's results as numbers
    __main__.py             75  Command line
    cli/                  1138  The command line's parts: python -m e2vlib (__main__) runs them
      checks.py            365  Checks of command-line values before any work starts
      data_commands.py     166  The dataset commands
      model_commands.py    273  The model commands
      parser.py            213  The command line's parser
      study_commands.py     89  The study command

End of the module map.
"""

__version__ = "0.1.0"
