"""Trained Gaussian-splat models as the official code writes them
(graphdeco-inria/gaussian-splatting scene/gaussian_model.py save_ply: float32
x y z nx ny nz f_dc_0..2 f_rest_* opacity scale_* rot_0..3, binary little
endian, the activations undone), and read back with the official
activations (load_ply: sigmoid, exp, normalised quaternion), for tests that
give the same model to refrender and to a numpy reference. Written from the
layout alone, not from refrender's C."""
import numpy as np


def write(path, model):
    """model: mean (N,3), scale (N,2 or 3) activated, rot (N,4 wxyz), opacity (N,) activated, sh (N,K,3)."""
    mean = np.asarray(model["mean"], np.float64)
    n, k = len(mean), np.asarray(model["sh"]).shape[1]
    sh = np.asarray(model["sh"], np.float64)
    rest = sh[:, 1:, :].transpose(0, 2, 1).reshape(n, 3 * (k - 1))  # channel-major: all R, then G, then B
    scale = np.asarray(model["scale"], np.float64)
    op = np.asarray(model["opacity"], np.float64)
    cols = [mean, np.zeros((n, 3)), sh[:, 0, :], rest, np.log(op / (1 - op))[:, None], np.log(scale),
            np.asarray(model["rot"], np.float64)]
    names = (["x", "y", "z", "nx", "ny", "nz", "f_dc_0", "f_dc_1", "f_dc_2"] +
             [f"f_rest_{i}" for i in range(3 * (k - 1))] + ["opacity"] +
             [f"scale_{i}" for i in range(scale.shape[1])] + ["rot_0", "rot_1", "rot_2", "rot_3"])
    data = np.concatenate(cols, axis=1).astype("<f4")
    head = "ply\nformat binary_little_endian 1.0\nelement vertex %d\n" % n
    head += "".join(f"property float {p}\n" for p in names) + "end_header\n"
    with open(path, "wb") as f:
        f.write(head.encode() + data.tobytes())


def read(path):
    """The model as the official loader activates it (float64 from the stored float32)."""
    data = open(path, "rb").read()
    head, _, body = data.partition(b"end_header\n")
    lines = head.decode().splitlines()
    count = int(next(l for l in lines if l.startswith("element vertex")).split()[2])
    names = [l.split()[2] for l in lines if l.startswith("property float")]
    v = np.frombuffer(body, dtype="<f4").reshape(count, len(names)).astype(np.float64)
    col = {p: v[:, i] for i, p in enumerate(names)}
    nrest = sum(p.startswith("f_rest_") for p in names)
    k = nrest // 3 + 1
    rest = np.zeros((count, 3, 0)) if not nrest else np.stack([col[f"f_rest_{i}"] for i in range(nrest)], axis=1)
    rest = rest.reshape(count, 3, k - 1).transpose(0, 2, 1)
    dc = np.stack([col[f"f_dc_{c}"] for c in range(3)], axis=1)[:, None, :]
    q = np.stack([col[f"rot_{i}"] for i in range(4)], axis=1)
    nscale = sum(p.startswith("scale_") for p in names)
    return {"mean": np.stack([col[a] for a in "xyz"], axis=1),
            "scale": np.exp(np.stack([col[f"scale_{i}"] for i in range(nscale)], axis=1)),
            "rot": q / np.linalg.norm(q, axis=1)[:, None], "opacity": 1 / (1 + np.exp(-col["opacity"])),
            "sh": np.concatenate([dc, rest], axis=1), "degree": int(round(np.sqrt(k))) - 1}


def camera_xml(R_c2w, C, fy, W, H):
    """refrender's <camera> for an OpenCV camera-to-world rotation (columns x right, y down, z forward),
    centre C and square pixels of focal length fy: look along z, up = -y."""
    R, C = np.asarray(R_c2w, np.float64), np.asarray(C, np.float64)
    look, up = C + R[:, 2], -R[:, 1]
    fov = np.degrees(2 * np.arctan(H / (2.0 * fy)))
    f = lambda v: " ".join("%.17g" % x for x in v)
    return (f'<camera position="{f(C)}" lookat="{f(look)}" up="{f(up)}" fov="{fov:.17g}" width="{W}" '
            f'height="{H}"/>')


def rotation(yaw, pitch, roll=0.0):
    """A camera-to-world rotation for camera_xml: turned by roll about z, then pitch about x, then yaw
    about y (R = Ry Rx Rz), so the Gaussian tests' cameras are written one way."""
    cy, sy, cp, sp, cr, sr = np.cos(yaw), np.sin(yaw), np.cos(pitch), np.sin(pitch), np.cos(roll), np.sin(roll)
    ry = np.array([[cy, 0, sy], [0, 1, 0], [-sy, 0, cy]])
    rx = np.array([[1, 0, 0], [0, cp, -sp], [0, sp, cp]])
    rz = np.array([[cr, -sr, 0], [sr, cr, 0], [0, 0, 1]])
    return ry @ rx @ rz
