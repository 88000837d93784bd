"""The paper's facts as named constants, and our documented choices kept apart from them.

Chen, Chung, Tan, Chen, *Dense Voxel 3D Reconstruction Using a Monocular Event Camera*,
ICVR 2023, pp. 30-35 (doi:10.1109/ICVR57957.2023.10169359). Every other module imports
these names instead of retyping the numbers; each constant says where in the paper it
comes from. ``describe()`` shows them as a table, each with where it comes from.

The second half of this file, "Our choices", holds values the paper does not state. Each
says why we picked it; lessons must present them as ours, never as the paper's.

Examples
--------
>>> from e2vlib import paper
>>> paper.N_EVENT_FRAMES * paper.DT_US == paper.RECORDING_US
True
>>> paper.CATEGORIES[:3]
('airplane', 'bench', 'cabinet')
>>> paper.TABLE_I["test"]["overall"]
0.352
"""

from __future__ import annotations

# ----------------------------------------------------------------------------- events
DT_US: int = 5_000
"""Delta t of one event frame, microseconds (Sec. III-A: "0.005 s")."""

RECORDING_US: int = 500_000
"""Length of one recording, microseconds (Sec. III-A and IV: 0.5 s of video)."""

N_EVENT_FRAMES: int = 100
"""Event frames per sample (Sec. III-A: a 0.5 s recording "could generate 100 event frames")."""

# ----------------------------------------------------------------------------- video
VIDEO_FPS: int = 240
"""Frame rate of the rendered orbit video (Sec. IV: 240 fps)."""

N_VIDEO_FRAMES: int = 120
"""Rendered video frames per orbit (Sec. IV: 240 fps for 0.5 s)."""

EVENT_SIMULATOR: str = "Vid2E"
"""How the paper turns its rendered video into events (Sec. IV: the Video to Events method of
Gehrig et al., CVPR 2020); its settings (contrast threshold, noise) are not given."""

FOCAL_LENGTH_MM: float = 80.0
"""Focal length of the virtual camera (Sec. IV: 80 mm). The sensor width is not given."""

RENDER_SIZE_PX: int = 512
"""Side of the rendered video frames (Sec. IV: 512 x 512 px)."""

INPUT_SIZE_PX: int = 256
"""Side of the frames the network reads, scaled from 512 (Sec. III-B, written "512^3 to 256^3")."""

ORBIT_Z_TOP_M: float = 2.0
"""Camera height at the start of the orbit (Sec. IV: z from +2 m ...)."""

ORBIT_Z_BOTTOM_M: float = -2.0
"""Camera height at the end of the orbit (Sec. IV: ... to -2 m)."""

ORBIT_SIZE_END_M: float = 4.0
"""Size of the orbit at z = +-2 m (Sec. IV: "a starting radius of 4 m"; see ORBIT_SIZE_MID_M)."""

ORBIT_SIZE_MID_M: float = 6.0
"""Size of the orbit at z = 0 (Sec. IV: the path's "diameter" grows from 4 m to 6 m; the
text calls the same number a radius and a diameter, see :data:`ORBIT_READING`)."""

# ----------------------------------------------------------------------------- objects
GRID_SIDE: int = 32
"""Side of the output voxel grid (Sec. III: dense 32^3 occupancy, as Pix2Vox++)."""

CATEGORIES: tuple[str, ...] = (
    "airplane", "bench", "cabinet", "car", "chair", "display", "lamp",
    "speaker", "rifle", "sofa", "table", "telephone", "watercraft",
)
"""The 13 ShapeNet categories, in the column order of Tables I and II."""

SHAPENET_SYNSETS: dict[str, str] = {
    "02691156": "airplane",
    "02828884": "bench",
    "02933112": "cabinet",
    "02958343": "car",
    "03001627": "chair",
    "03211117": "display",
    "03636649": "lamp",
    "03691459": "speaker",
    "04090263": "rifle",
    "04256520": "sofa",
    "04379243": "table",
    "04401088": "telephone",
    "04530566": "watercraft",
}
"""ShapeNetCore synset id (WordNet offset, the folder name) -> category, for the 13
(ShapeNetCore's own taxonomy; the paper names the categories, not the ids)."""

OBJECT_SIZE_M: float = 1.0
"""ShapeNet models are normalised to fit within 1 m^3 (Sec. IV)."""

N_SCANS: int = 39_739
"""Scans in the authors' dataset, 13 categories (Sec. IV)."""

N_TRAIN, N_VAL, N_TEST = 832, 104, 104
"""Randomly selected training, validation and test samples (Sec. V)."""

N_LARGE_TEST: int = 8_770
"""Samples of the "large testing" set (Sec. V, Tables I-II)."""

# ----------------------------------------------------------------------------- model
N_PARAMETERS: int = 149_155_905
"""Parameters of E2V: 3D ResNet-152 encoder + UNet-like decoder (Sec. III-B)."""

RESNET_DEPTH: int = 152
"""Depth of the ResNet whose 2D convolutions become 3D ones (Sec. III-B)."""

# ----------------------------------------------------------------------------- training
EPOCHS: int = 100
"""Training epochs (Sec. V)."""

BATCH_SIZE: int = 5
"""Batch size (Sec. V)."""

LEARNING_RATE: float = 1e-5
"""AdamW learning rate (Sec. V: 0.00001)."""

OPTIMIZER: str = "AdamW"
"""Optimizer (Sec. V); the loss is mean binary cross-entropy over all voxels (Eq. in Sec. III-C)."""

ADAMW_SETTINGS_STATED: tuple[str, ...] = ("lr",)
"""The AdamW settings the paper states (Sec. V): the learning rate only; its weight decay, betas
and schedule are not given (every recipe's weight decay is ours)."""

# ----------------------------------------------------------------------------- results
FSCORE_DISTANCE_REPORTED: float = 0.20
"""The F-score distance the paper reports, "F-Score@20 %" (Sec. V: F@1 % "drops to zero")."""

GALLERY_FIGURE: int = 4
"""The paper's figure of test reconstructions (Fig. 4: a "Ground Truth" row above an "E2V Result"
row, one column per category; Fig. 1 is the architecture, Figs. 2-3 the camera setup)."""


def _table(values: str, overall: float) -> dict[str, float]:
    numbers = [float(v) for v in values.split()]
    assert len(numbers) == len(CATEGORIES)
    return {**dict(zip(CATEGORIES, numbers, strict=True)), "overall": overall}


TABLE_I: dict[str, dict[str, float]] = {
    "train": _table(".652 .697 .879 .710 .740 .817 .681 .807 .597 .746 .801 .882 .643", 0.742),
    "test": _table(".485 .293 .405 .520 .261 .310 .158 .190 .512 .400 .297 .377 .372", 0.352),
    "large_test": _table(
        ".424 .364 .344 .518 .234 .310 .182 .240 .426 .355 .250 .488 .361", 0.346),
}
"""Table I, IoU per category and overall, for the train (832), test (104) and large test
(8,770) sets. The paper does not say at which threshold."""

TABLE_II: dict[str, dict[str, float]] = {
    "train": _table(".291 .268 .167 .191 .168 .264 .283 .160 .375 .185 .220 .379 .257", 0.247),
    "test": _table(".182 .091 .068 .117 .050 .079 .082 .040 .310 .105 .081 .147 .150", 0.116),
    "large_test": _table(
        ".164 .118 .068 .116 .054 .078 .087 .052 .252 .078 .067 .205 .112", 0.112),
}
"""Table II, F-Score@20 % per category and overall, same sets as :data:`TABLE_I`."""

TABLE_III: dict[str, float] = {
    "3D-R2N2": 0.636,
    "AttSets": 0.693,
    "Pix2Vox++": 0.706,
    "EVolT": 0.735,
    "E2V": 0.346,
}
"""Table III, mIoU of RGB image-based methods (about 30,000 training samples) and of E2V
(832 training samples, the large test set)."""

# ============================================================================= our choices
# The paper does not state the values below. Each is ours; lessons say so.

CONTRAST_THRESHOLD: float = 0.2
"""ESIM log-intensity contrast threshold C (ours; the paper gives no simulator settings).
0.2 is a common default of ESIM/Vid2E-style simulators and keeps 128 px orbits near
100 k events."""

IOU_THRESHOLD: float = 0.3
"""Voxelisation threshold t for IoU (ours: Pix2Vox's convention for its headline number;
the paper's Eq. 6 has a threshold but never names its value)."""

IOU_THRESHOLDS: tuple[float, ...] = (0.2, 0.3, 0.4, 0.5)
"""The thresholds Pix2Vox reports IoU at; we report all four (ours)."""

FSCORE_DISTANCE: float = 0.01
"""F-score distance in unit-cube lengths (ours: the usual 1 % of Pix2Vox++/Tatarchenko et al.)."""

SENSOR_WIDTH_MM: float = 36.0
"""Sensor width of our virtual camera (ours: a full-frame 36 mm sensor, Blender's default
sensor width; the paper gives only the 80 mm focal length). View angle about 25.4 degrees."""

ORBIT_READING: str = "radius"
"""How we read the orbit's "4 m ... 6 m" (ours: as horizontal radii, 4 m at z = +-2 and 6 m
at z = 0, matching the paper's "starting radius of 4 m"; read as diameters the camera would
come within 2.8 m, where the 1.27 m wide view of an 80 mm lens on a 36 mm sensor leaves a
1 m object's corners outside the frame)."""

FRAME_WINDOWS: str = "fixed"
"""How events are grouped into frames by default (ours: fixed clock windows
[t0 + k dt, t0 + (k+1) dt), which always give exactly 100 frames per 0.5 s; the paper's
Eq. 5 grouping is ``frames.accumulate(..., windows="paper")``)."""

RESOLUTION_PX: int = 128
"""Rendered and simulated image side of data_small (ours; the paper renders 512 px). 128 px
keeps a sample near one second of CPU time."""

FRAME_SIZE_PX: int = 64
"""Side of the stored frames of data_small after max-pooling (ours; the paper's 256)."""


# ============================================================================= a student's view


def _documented_constants() -> list[tuple[str, str, bool]]:
    """``[(name, docstring, is_ours)]`` for every constant of this file with a docstring,
    in file order (read with ``ast``, so the docstrings need not be repeated anywhere)."""
    import ast
    from pathlib import Path

    source = Path(__file__).read_text()
    ours_from = source.index("=" * 77 + " our choices")
    tree = ast.parse(source)
    found = []
    body = tree.body
    for node, following in zip(body, body[1:], strict=False):
        if not (isinstance(following, ast.Expr) and isinstance(following.value, ast.Constant)
                and isinstance(following.value.value, str)):
            continue
        if isinstance(node, ast.AnnAssign) and isinstance(node.target, ast.Name):
            names = [node.target.id]
        elif isinstance(node, ast.Assign) and isinstance(node.targets[0], (ast.Name, ast.Tuple)):
            target = node.targets[0]
            names = [target.id] if isinstance(target, ast.Name) else [e.id for e in target.elts]
        else:
            continue
        doc = " ".join(following.value.value.split())
        offset = sum(len(line) + 1 for line in source.splitlines()[:node.lineno - 1])
        found += [(name, doc, offset > ours_from) for name in names]
    return found


def _short(value) -> str:
    if isinstance(value, dict) and all(isinstance(v, dict) for v in value.values()):
        return "; ".join(f"{k}: {v['overall']}" for k, v in value.items()) + " (overall)"
    if isinstance(value, dict):
        if len(value) > 6:
            return f"{len(value)} entries"
        return ", ".join(f"{k} {v}" for k, v in value.items())
    if isinstance(value, tuple):
        return ", ".join(str(v) for v in value)
    if isinstance(value, int) and not isinstance(value, bool) and abs(value) >= 10_000:
        return f"{value:,}"
    return str(value)


def describe(names=None, ours: bool | None = None) -> str:
    """A markdown table of the paper's facts (and, apart, our choices): name, value, source.

    ``names`` picks constants (default: all); ``ours=False`` keeps only the paper's facts,
    ``ours=True`` only our choices. In a notebook, show it with
    ``IPython.display.Markdown(paper.describe(...))``.

    Examples
    --------
    >>> print(describe(["DT_US"]))
    | constant | value | where it comes from |
    | --- | --- | --- |
    | `DT_US` | 5000 | paper: Delta t of one event frame, microseconds (Sec. III-A: "0.005 s"). |
    >>> "| `IOU_THRESHOLD` | 0.3 | **our choice**: " in describe(["IOU_THRESHOLD"])
    True
    """
    constants = _documented_constants()
    known = {name for name, _, _ in constants}
    if names is not None:
        unknown = [n for n in names if n not in known]
        if unknown:
            raise KeyError(f"no documented constant {unknown} in e2vlib.paper; "
                           f"known: {sorted(known)}")
        order = {name: i for i, name in enumerate(names)}
        constants = sorted((c for c in constants if c[0] in order), key=lambda c: order[c[0]])
    if ours is not None:
        constants = [c for c in constants if c[2] == ours]
    lines = ["| constant | value | where it comes from |", "| --- | --- | --- |"]
    for name, doc, is_ours in constants:
        source = "**our choice**" if is_ours else "paper"
        value = _short(globals()[name])
        lines.append(f"| `{name}` | {value} | {source}: {doc.replace('|', '/')} |")
    return "\n".join(lines)
