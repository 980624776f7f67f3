"""nerfstudio's transforms.json parsing, written from its source for tests/test_dataset.py (not
from scripts/dataset.py): nerfstudio-project/nerfstudio at commit
01595f7fb5575e519f2372fa8672fe963579e4d1, nerfstudio/data/dataparsers/nerfstudio_dataparser.py,
Nerfstudio._generate_dataparser_outputs.

What the source does and what this file keeps:
- meta = transforms.json; fl_x, fl_y, cx, cy, h, w each either top level ("fixed") or required in
  every frame (an assert otherwise); k1 k2 k3 p1 p2 top level or per frame;
- the frames sorted by their file name (argsort of the paths), each's file_path and
  transform_matrix (camera-to-world, OpenGL axes) taken;
- the split: if any of train_filenames / val_filenames / test_filenames is in meta, the split's
  list must be there (else RuntimeError) and every name in it must be a frame's (else
  RuntimeError); the split's indices are the sorted frames whose name is in it. Without them the
  eval_mode rules (fraction 0.9 by default) apply; not reproduced here;
- the poses are then oriented, centred and scaled (auto_orient_and_center_poses,
  auto_scale_poses): not reproduced; tests compare the poses before it (orientation_method
  "none", center_method "none", auto_scale_poses False, which its config allows);
- the downscale factor: 1 for images under 1600 pixels (_get_fname), so a file is
  data_dir / file_path."""
import json
from pathlib import Path

import numpy as np


def parse(data_dir, split):
    data_dir = Path(data_dir)
    meta = json.loads((data_dir / "transforms.json").read_text())
    keys = ("fl_x", "fl_y", "cx", "cy", "h", "w")
    fixed = {k: k in meta for k in keys}
    fnames = [data_dir / Path(f["file_path"]) for f in meta["frames"]]
    frames = [meta["frames"][i] for i in np.argsort([str(f) for f in fnames])]
    names, poses, per_frame = [], [], {k: [] for k in keys}
    for frame in frames:
        for k in keys:
            if not fixed[k]:
                assert k in frame, f"{k} not specified in frame"
                per_frame[k].append(float(frame[k]))
        names.append(data_dir / Path(frame["file_path"]))
        poses.append(np.array(frame["transform_matrix"], dtype=np.float64))
    has_split = any(f"{s}_filenames" in meta for s in ("train", "val", "test"))
    if f"{split}_filenames" in meta:
        wanted = set(data_dir / Path(x) for x in meta[f"{split}_filenames"])
        missing = wanted.difference(names)
        if missing:
            raise RuntimeError(f"Some filenames for split {split} were not found: {missing}.")
        indices = [i for i, n in enumerate(names) if n in wanted]
    elif has_split:
        raise RuntimeError(f"The dataset's list of filenames for split {split} is missing.")
    else:
        raise NotImplementedError("eval_mode splits are not reproduced here")
    intr = {k: (float(meta[k]) if fixed[k] else np.array(per_frame[k])[indices]) for k in keys}
    poses = np.array(poses, dtype=np.float32)[indices]
    return {"image_filenames": [names[i] for i in indices], "camera_to_worlds": poses[:, :3, :4],
            "camera_model": meta.get("camera_model", "PERSPECTIVE"), **intr,
            "distortion": [float(meta.get(k, 0.0)) for k in ("k1", "k2", "k3", "p1", "p2")], "meta": meta}
