"""Real objects of the paper's categories from Debian packages: the catalogue.

FlightGear's aircraft, boats, road vehicles and street lamps, TORCS's cars, UFO:AI's and
OpenArena's guns, GL-117's aircraft, minetest's home decor and Sweet Home 3D's own
furniture, downloaded and unpacked (never installed) under ``cache/real_objects``, looked
at model by model, and listed with the 241 reviewed Sweet Home 3D / crrcsim models of
:mod:`e2vlib.experiments.real_meshes` in one committed table,
``experiments/real_objects/catalogue.csv`` (no geometry: source, path, licence, category,
rotation, parts removed, keep, split, what looking showed). The modules, each with one job:

==========================  ================================================================
``real_objects.sources``    the packages (:data:`~sources.PACKAGES`), ``apt-get download``
                            and ``dpkg-deb -x``, the candidate models (:data:`~sources.RULES`)
``real_objects.readers``    AC3D/ACC, OBJ, MD2 (a numpy reader), 3DS/MD3 (assimp) into
                            our frame (z up, front -y, centred, longest side 1)
``real_objects.look``       surface grids, contact sheets, duplicates by geometry
``real_objects.catalogue``  the committed table: :func:`~catalogue.read_catalogue`,
                            :func:`~catalogue.check_catalogue`, the split
``real_objects.build``      joins candidates, the review and the duplicates into the table
``real_objects.labels``     solid 32^3 labels of open, many-part meshes
                            (:func:`~labels.solid_labels`)
``real_objects.samples``    the kept rows as a dataset folder models train on
                            (:func:`~samples.build_samples`, in ``cache/``)
``real_objects.study``      the ``real_objects`` study: four ways to train, the learning
                            curve, the hull with poses (:func:`~study.run_real_objects`)
``real_objects.ship``       the CC0 / CC-BY rows' samples with their credits, committed as
                            ``data_small/real_objects`` (:func:`~ship.ship_samples`)
``real_objects.__main__``   the recorded commands (download, extract, grids, sheets,
                            catalogue, samples, study, ship)
==========================  ================================================================

Nothing derived from the GPL or CC-BY-SA models (grids, sheets, meshes, samples, trained
weights) leaves ``cache/``.
The core never imports this package.
"""
