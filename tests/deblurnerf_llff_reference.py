"""Deblur-NeRF's LLFF loading, written from its source for tests/test_dataset.py (not from
scripts/dataset.py): limacv/Deblur-NeRF at commit 9c53976561a49b70997a9adc113c3cdb575b5ab4,
load_llff.py (_load_data, load_llff_data) and run_nerf.py (train(): the llffhold split).

What the source does, step by step, and what this file keeps:
- _load_data: poses_bounds.npy is N x 17; [:, :-2] reshaped to [-1, 3, 5] and transposed to
  [3, 5, N]; [:, -2:] are the bounds (near, far). With a factor, images come from
  'images_<factor>' (made by _minify only when it is missing); the image files are those of that
  directory, sorted by name, ending in 'JPG', 'jpg' or 'png'; a count unlike the poses' returns
  None. The first image's shape overwrites each pose's h, w; its focal is divided by the factor.
  A PNG is read as stored (imageio ignoregamma=True), RGB only, / 255. (Read here with
  OpenImageIO as stored 8-bit values: the same numbers, without imageio.)
- load_llff_data: the columns [down, right, back] become [right, up, back] by
  concatenate([p[:, 1:2], -p[:, 0:1], p[:, 2:]], 1); with bd_factor, translations and bounds are
  scaled by 1 / (min bound * bd_factor); recentering (recenter_poses) is not reproduced here:
  tests compare the poses before it (recenter=False), which the loader allows.
- run_nerf.py: i_test = arange(N)[::llffhold], i_val = i_test, i_train the rest; the intrinsics
  K = [[focal, 0, W/2], [0, focal, H/2], [0, 0, 1]]."""
import os

import numpy as np
import OpenImageIO as oiio


def _imread(path):
    inp = oiio.ImageInput.open(str(path))
    assert inp, oiio.geterror()
    pixels = inp.read_image(oiio.UINT8)
    inp.close()
    return pixels


def load_data(basedir, factor=1):
    poses_arr = np.load(os.path.join(basedir, "poses_bounds.npy"))
    poses = poses_arr[:, :-2].reshape([-1, 3, 5]).transpose([1, 2, 0])
    bds = poses_arr[:, -2:].transpose([1, 0])
    imgdir = os.path.join(basedir, f"images_{factor}")
    assert os.path.exists(imgdir), f"{imgdir} missing: Deblur-NeRF would try to make it with mogrify"
    names = [f for f in sorted(os.listdir(imgdir)) if f.endswith("JPG") or f.endswith("jpg") or f.endswith("png")]
    files = [os.path.join(imgdir, f) for f in names]
    if poses.shape[-1] != len(files):
        return None
    shape = _imread(files[0]).shape
    poses[:2, 4, :] = np.array(shape[:2]).reshape([2, 1])
    poses[2, 4, :] = poses[2, 4, :] / factor
    imgs = np.stack([_imread(f)[..., :3] / 255.0 for f in files], -1)
    return poses, bds, imgs, names


def load_llff_data(basedir, factor=1, bd_factor=0.75, llffhold=8):
    """images [N, H, W, 3], poses [N, 3, 5] (camera-to-world [right, up, back | t] and h, w, f),
    bounds [N, 2], the file names, and run_nerf's i_train, i_test."""
    loaded = load_data(basedir, factor)
    assert loaded is not None, "Mismatch between imgs and poses"
    poses, bds, imgs, names = loaded
    poses = np.concatenate([poses[:, 1:2, :], -poses[:, 0:1, :], poses[:, 2:, :]], 1)
    poses = np.moveaxis(poses, -1, 0).astype(np.float32)
    images = np.moveaxis(imgs, -1, 0).astype(np.float32)
    bds = np.moveaxis(bds, -1, 0).astype(np.float32)
    sc = 1.0 if bd_factor is None else 1.0 / (bds.min() * bd_factor)
    poses[:, :3, 3] *= sc
    bds *= sc
    i_test = np.arange(images.shape[0])[::llffhold]
    i_train = np.array([i for i in np.arange(images.shape[0]) if i not in i_test])
    return images, poses, bds, names, i_train, i_test
