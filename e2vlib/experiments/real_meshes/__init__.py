"""Real third-party meshes of the paper's categories, from Debian's ``sweethome3d-furniture``.

Debian's furniture libraries (``apt-get install sweethome3d-furniture``; the aircraft come
from ``crrcsim-data``) give real models made by people, under CC0 or CC-BY (the aircraft
GPL-2.0, read where the package installs them and never shipped). A reviewed table,
``data_small/real/catalogue.csv``, keeps 241 of them (23 aircraft) in the paper's 13
categories; each is loaded in the project's frame (z up, front -y, bounding box centred,
longest side 1) and built into a test sample by the data_small protocol, so models trained
on data_small read it as they read its test split; :mod:`e2vlib.experiments.real_study`
scores them. Every public name is importable from here
(``from e2vlib.experiments.real_meshes import read_mapping, load_entry_mesh``); the code lives
in five modules, each with one job:

==========================  ================================================================
``real_meshes.catalogue``   the installed libraries: :func:`read_catalogue` of one ``.sh3f``
                            (:class:`CatalogueEntry`; :func:`parse_properties` reads its
                            Java properties), :func:`installed_libraries`,
                            :func:`read_all_catalogues`, licences (:func:`entry_licence`,
                            :func:`licence_from_text`, :data:`LIBRARY_LICENCES`,
                            :data:`LICENCES`), crrcsim-data's aircraft
                            (:func:`crrcsim_entry`), :class:`RealMeshError` and where the
                            packages install (:data:`FURNITURE_DIR`, :data:`CRRCSIM_DIR`)
``real_meshes.mapping``     the reviewed table: :func:`read_mapping`,
                            :func:`check_mapping` (:class:`MappedEntry`,
                            :data:`MAPPING_FIELDS`, :data:`MAPPING_CSV`), :func:`resolve`
                            (each row with its installed entry)
``real_meshes.ac3d``        :func:`ac3d_to_mesh`, a small reader of AC3D (``.ac``) files
``real_meshes.meshes``      one entry as a mesh in our frame: :func:`load_entry_mesh`,
                            :func:`obj_to_mesh`, :func:`entry_transform`,
                            :data:`SH3D_TO_ZUP`, :data:`POSES`
``real_meshes.build``       the test set: :func:`build_real_dataset` (``make-data
                            --real-meshes``), :func:`real_config`,
                            :func:`real_sample_seed`, :data:`BUILD_COMMAND`
==========================  ================================================================

Imports run one way: ``catalogue`` imports no other module of this package; ``ac3d``
imports ``catalogue``; ``meshes`` those two; ``mapping`` ``catalogue`` and ``meshes``
(:data:`POSES`); ``build`` all but ``ac3d`` and, when it builds, :mod:`e2vlib.data`; none
imports this ``__init__``.

Scored by :mod:`e2vlib.experiments.real_study` (experiments/results/real_meshes.json).
"""

import lazy_loader

__getattr__, __dir__, __all__ = lazy_loader.attach(
    __name__,
    submod_attrs={
        "ac3d": ["MAX_AC3D_DEPTH", "ac3d_to_mesh"],
        "build": [
            "BUILD_COMMAND", "build_real_dataset", "real_config", "real_sample_seed", "row_source",
        ],
        "catalogue": [
            "CATALOGUE_FILE", "CRRCSIM", "CRRCSIM_COPYRIGHT", "CRRCSIM_CREATOR", "CRRCSIM_DIR",
            "CRRCSIM_INSTALL_HINT", "FURNITURE_DIR", "INSTALL_HINT", "LIBRARY_CODES",
            "LIBRARY_LICENCES", "LICENCES", "MAX_CATALOGUE_BYTES", "MAX_LICENCE_BYTES",
            "MAX_MODEL_BYTES", "MAX_MODEL_COORDINATE", "MIN_MODEL_EXTENT", "ZIP_METHODS",
            "CatalogueEntry", "check_model_extent", "crrcsim_entry", "entry_licence",
            "installed_libraries", "licence_from_text", "open_library", "parse_properties",
            "read_all_catalogues", "read_catalogue", "read_member", "RealMeshError",
        ],
        "mapping": [
            "MAPPING_CSV", "MAPPING_FIELDS", "MAX_MAPPING_BYTES", "check_mapping", "MappedEntry",
            "read_mapping", "resolve",
        ],
        "meshes": ["POSES", "SH3D_TO_ZUP", "entry_transform", "load_entry_mesh", "obj_to_mesh"],
    },
)
