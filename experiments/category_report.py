"""Per-category oracle IoU@0.3 (category mean shape of the training split, scored on the test split)
and the labels' mean pairwise IoU@0.5 within the training split.

Usage: python experiments/category_report.py DATASET OUT.json
"""

import json
import sys

import numpy as np
import torch

from e2vlib.data import E2VDataset
from e2vlib.inputs import preload
from e2vlib.metrics import category_means, iou
from e2vlib.train import category_mean_shapes

root, out = sys.argv[1], sys.argv[2]
train, test = preload(E2VDataset(root, "train")), preload(E2VDataset(root, "test"))
means = category_mean_shapes(train)
res = {}
guess = torch.stack([means[c] for c in test.categories])
oracle_of = category_means(iou(guess, test.voxels, 0.3), test.categories)
for c, oracle in oracle_of.items():
    lab = train.voxels[torch.from_numpy(np.flatnonzero(np.asarray(train.categories) == c))].numpy()
    pair = [
        iou(lab[i].astype(np.float32), lab[j], 0.5)
        for i in range(len(lab))
        for j in range(i + 1, len(lab))
    ]
    res[c] = {"oracle_iou@0.3": oracle, "label_mean_pairwise_iou": float(np.mean(pair))}
json.dump(res, open(out, "w"), indent=1)
for c, v in res.items():
    print(f"{c:11s} oracle {v['oracle_iou@0.3']:.3f} pairwise {v['label_mean_pairwise_iou']:.3f}")
