"""COLMAP sparse models and LLFF poses_bounds.npy as <camera> sources (issue 59 item 2).

The files are written here by writers of our own, from the formats' documents and the code that
writes them, not from refrender's C: COLMAP's cameras.bin/images.bin records as
scripts/python/read_write_model.py (colmap 3.11.1, 106-357) packs them ('<Q' count; a camera
'<iiQQ' + its doubles; an image '<idddddddi', its name NUL-terminated, '<Q' points and 'ddq' each)
and the text files as COLMAP writes them (reconstruction_io_text.cc 4.1.1, 440-565: comment lines,
an image line then its POINTS2D line); the pose is cam_from_world, q = (w, x, y, z) of R^T and
t = -R^T C for a camera of centre C whose axes (x right, y down, z forward) are R's columns.
poses_bounds.npy as LLFF's imgs2poses builds it (Fyusion/LLFF c6e27b1 pose_utils.py 44-51, 85):
the camera-to-world matrix with its columns re-ordered to [down, right, back] = [R1, R0, -R2], the
centre, then [height, width, focal], raveled row-major, and two bounds; np.save writes '<f8'.

The expectation (the issue's "done when"): each source's camera gives the pose the same scene's
cameras.json gives, exported by `refrender export` (camera_to_raster, and world_to_camera at each
time of a two-pose motion), within 1e-9, and that pose is diag(1, -1, 1) [R^T | -R^T C] (export's
camera space is y up), derived here. A COLMAP principal point off the centre is kept: the exported
camera_to_raster holds cx and cy, and a sub-pixel Gaussian renders within 0.1 pixel of COLMAP's
projection (fx x / z + cx, fy y / z + cy; models.h: the upper-left corner is (0, 0)). One frame
rendered through each source equals the cameras.json render. Each hostile input is refused with
exit 1 and a message naming the file and the record (line, record number or row)."""
import json
import shutil
import struct
import subprocess

import numpy as np
import pytest

import gsply
from conftest import ROOT, coverage_centroid, read_exr, run

W, H = 96, 64
FX, FY = 80.0, 95.0  # the shared cameras' pixels are square (LLFF has one focal); FY for a COLMAP PINHOLE's own


def rot(axis, angle):
    a = np.asarray(axis, float) / np.linalg.norm(axis)
    K = np.array([[0, -a[2], a[1]], [a[2], 0, -a[0]], [-a[1], a[0], 0]])
    return np.eye(3) + np.sin(angle) * K + (1 - np.cos(angle)) * K @ K


def quat_of(R):
    """Hamilton (w, x, y, z) of a rotation matrix (Shepperd's method: the largest diagonal term)."""
    t = np.trace(R)
    if t > 0:
        s = 2 * np.sqrt(1 + t)
        return np.array([s / 4, (R[2, 1] - R[1, 2]) / s, (R[0, 2] - R[2, 0]) / s, (R[1, 0] - R[0, 1]) / s])
    i = int(np.argmax(np.diag(R)))
    j, k = (i + 1) % 3, (i + 2) % 3
    s = 2 * np.sqrt(1 + R[i, i] - R[j, j] - R[k, k])
    q = np.zeros(4)
    q[0] = (R[k, j] - R[j, k]) / s
    q[1 + i] = s / 4
    q[1 + j] = (R[j, i] + R[i, j]) / s
    q[1 + k] = (R[k, i] + R[i, k]) / s
    return q if q[0] >= 0 else -q


# three cameras (axes as R's columns, centre C) looking roughly at the origin
CAMS = {"A.png": (rot([0.3, 1, 0.2], 0.5) @ rot([1, 0, 0], 0.2), np.array([0.4, -0.3, -3.0])),
        "B.png": (rot([0.1, 0.4, 1], 0.25) @ rot([0.3, 1, 0.2], 0.5) @ rot([1, 0, 0], 0.2),
                  np.array([0.9, -0.1, -2.8])),
        "C.png": (rot([1, 0.2, 0.1], -0.3), np.array([-0.5, 0.6, -3.1]))}
IDS = {"A.png": 3, "B.png": 7, "C.png": 1}  # COLMAP image ids need not follow the names
P = CAMS["A.png"][1] + CAMS["A.png"][0] @ np.array([0.25, -0.1, 3.2])  # in front of A


def write_cameras_json(path):
    path.write_text(json.dumps([{"id": i, "img_name": n, "width": W, "height": H, "position": list(map(float, C)),
                                 "rotation": [list(map(float, r)) for r in R], "fx": FX, "fy": FX}
                                for i, (n, (R, C)) in enumerate(CAMS.items())]))


def colmap_records(model="PINHOLE", params=None):
    params = params or ([FX, FX, W / 2, H / 2] if model == "PINHOLE" else [FX, W / 2, H / 2])
    images = []
    for name, (R, C) in CAMS.items():
        images.append((IDS[name], quat_of(R.T), -R.T @ C, 2, name))
    return [(2, model, W, H, params)], images


MODEL_IDS = {"SIMPLE_PINHOLE": 0, "PINHOLE": 1, "OPENCV": 4}


def write_colmap_binary(d, cameras, images, points=2):
    d.mkdir(exist_ok=True)
    with open(d / "cameras.bin", "wb") as f:
        f.write(struct.pack("<Q", len(cameras)))
        for cid, model, w, h, params in cameras:
            f.write(struct.pack("<iiQQ", cid, MODEL_IDS[model], w, h) + struct.pack("<" + "d" * len(params), *params))
    with open(d / "images.bin", "wb") as f:
        f.write(struct.pack("<Q", len(images)))
        for iid, q, t, cid, name in images:
            f.write(struct.pack("<idddddddi", iid, *q, *t, cid) + name.encode() + b"\0")
            f.write(struct.pack("<Q", points) + struct.pack("<" + "ddq" * points, *([5.5, 6.5, -1] * points)))


def write_colmap_text(d, cameras, images):
    d.mkdir(exist_ok=True)
    lines = ["# Camera list with one line of data per camera:", "#   CAMERA_ID, MODEL, WIDTH, HEIGHT, PARAMS[]"]
    lines += [" ".join(map(str, [cid, model, w, h] + [repr(float(p)) for p in params]))
              for cid, model, w, h, params in cameras]
    (d / "cameras.txt").write_text("\n".join(lines) + "\n")
    lines = ["# Image list with two lines of data per image:", "#   IMAGE_ID, QW, QX, QY, QZ, TX, TY, TZ, CAMERA_ID, NAME",
             "#   POINTS2D[] as (X, Y, POINT3D_ID)"]
    for k, (iid, q, t, cid, name) in enumerate(images):
        lines.append(" ".join([str(iid)] + [repr(float(v)) for v in [*q, *t]] + [str(cid), name]))
        lines.append("" if k % 2 else "5.5 6.5 -1 7.5 8.5 12")  # an empty POINTS2D line is one too
    (d / "images.txt").write_text("\n".join(lines) + "\n")


def llff_rows(f=FX):
    rows = []
    for name in sorted(CAMS):  # imgs2poses: rows in sorted name order
        R, C = CAMS[name]
        m = np.concatenate([R[:, 1:2], R[:, 0:1], -R[:, 2:3], C[:, None], np.array([[H], [W], [f]])], 1)
        rows.append(np.concatenate([m.ravel(), [1.5, 9.0]]))
    return np.array(rows)


def write_llff(d, rows=None, images=True):
    d.mkdir(exist_ok=True)
    np.save(d / "poses_bounds.npy", llff_rows() if rows is None else rows)
    if images:
        (d / "images").mkdir(exist_ok=True)
        for name in CAMS:
            (d / "images" / name).write_bytes(b"")
        (d / "images" / "notes.txt").write_text("not an image: not counted")


def gaussian(tmp_path, scale=1e-4):
    gsply.write(tmp_path / "g.ply", {"mean": np.array([P]), "scale": np.array([[scale, scale]]),
                                     "rot": np.array([[1.0, 0, 0, 0]]), "opacity": np.array([0.9]),
                                     "sh": np.full((1, 1, 3), 1.0), "degree": 0})


def scene(tmp_path, source, select, inner="", name="s.xml"):
    path = tmp_path / name
    close = "/>" if not inner else f">{inner}</camera>"
    path.write_text(f'<scene>\n<camera cameras="{source}" {select}{close}\n'
                    f'<object name="g"><gaussianModel file="g.ply"/></object></scene>')
    return path


@pytest.fixture
def sources(tmp_path):
    """Every source of the same three cameras: (cameras value, selection of A, motion A -> B)."""
    write_cameras_json(tmp_path / "cameras.json")
    write_colmap_binary(tmp_path / "bin", *colmap_records())
    write_colmap_text(tmp_path / "txt", *colmap_records())
    write_colmap_binary(tmp_path / "simple", *colmap_records("SIMPLE_PINHOLE", [FX, W / 2, H / 2]))
    write_llff(tmp_path / "llff")
    gaussian(tmp_path)
    by_name = ('image="A.png"', '<pose time="0" image="A.png"/><pose time="1" image="B.png"/>')
    return {"cameras.json": ("cameras.json",) + by_name,
            "colmap-bin": ("bin",) + by_name,
            "colmap-txt": ("txt",) + by_name,
            "colmap-id": ("bin", 'imageId="3"', '<pose time="0" imageId="3"/><pose time="1" imageId="7"/>'),
            "llff-name": ("llff/poses_bounds.npy",) + by_name,
            "llff-index": ("llff/poses_bounds.npy", 'index="0"', '<pose time="0" index="0"/><pose time="1" index="1"/>')}


def export(tmp_path, path):
    out = tmp_path / (path.stem + ".json")
    proc = run(["export", path, "-o", out])
    assert proc.returncode == 0, proc.stderr
    return json.loads(out.read_text())


def expected_world_to_camera(R, C):
    m = np.eye(4)
    m[:3, :3], m[:3, 3] = R.T, -R.T @ C
    return np.diag([1.0, -1, 1, 1]) @ m


def test_each_source_gives_the_poses_cameras_json_gives(tmp_path, sources):
    want = None
    for key, (src, select, poses) in sources.items():
        e = export(tmp_path, scene(tmp_path, src, select, f"<animation>{poses}</animation>", name=f"{key}.xml"))
        got = (np.array(e["camera"]["camera_to_raster"]), np.array(e["frames"][0]["world_to_camera"]))
        assert np.allclose(got[1][0], expected_world_to_camera(*CAMS["A.png"]), rtol=0, atol=1e-12), key
        assert np.allclose(got[1][-1], expected_world_to_camera(*CAMS["B.png"]), rtol=0, atol=1e-12), key
        want = want or (key, got)
        for a, b in zip(got, want[1]):
            assert np.allclose(a, b, rtol=0, atol=1e-9), (key, want[0], a, b)


def test_a_simple_pinhole_has_one_focal_length(tmp_path, sources):
    e = export(tmp_path, scene(tmp_path, "simple", 'image="C.png"'))
    assert np.allclose(e["camera"]["camera_to_raster"], [[FX, 0, W / 2, 0], [0, -FX, H / 2, 0], [0, 0, 0, 1],
                                                         [0, 0, 1, 0]], rtol=1e-12, atol=0)
    assert np.allclose(e["frames"][0]["world_to_camera"][0], expected_world_to_camera(*CAMS["C.png"]), atol=1e-12)


def test_an_off_centre_principal_point_renders_where_colmap_projects(tmp_path):
    cx, cy = 40.25, 37.5
    write_colmap_binary(tmp_path / "m", *colmap_records("PINHOLE", [FX, FY, cx, cy]))
    gaussian(tmp_path)
    path = scene(tmp_path, "m", 'image="A.png"')
    e = export(tmp_path, path)
    assert np.allclose(e["camera"]["camera_to_raster"], [[FX, 0, cx, 0], [0, -FY, cy, 0], [0, 0, 0, 1],
                                                         [0, 0, 1, 0]], rtol=1e-12, atol=1e-12)
    R, C = CAMS["A.png"]
    x, y, z = R.T @ (P - C)
    # rendered at half size (--res keeps the view: focal lengths and principal point halve)
    want = 0.5 * np.array([FX * x / z + cx, FY * y / z + cy])
    proc = run([path, "--res", f"{W // 2}x{H // 2}", "--spp", 16, "-o", tmp_path / "o.exr", "--quiet"])
    assert proc.returncode == 0, proc.stderr
    got = np.array(coverage_centroid(read_exr(tmp_path / "o.exr")[0][..., 3]))
    centred = 0.5 * np.array([FX * x / z + W / 2, FY * y / z + H / 2])
    assert np.linalg.norm(got - want) < 0.1 and np.linalg.norm(centred - want) > 2, (got, want)


def test_one_frame_renders_alike_through_every_source(tmp_path, sources):
    gaussian(tmp_path, 0.2)  # a few pixels wide at 24x16
    images = {}
    for key, (src, select, _) in sources.items():
        out = tmp_path / f"{key}.exr"
        proc = run([scene(tmp_path, src, select, name=f"{key}.xml"), "--res", "24x16", "--spp", 4, "--seed", 3, "-o",
                    out, "--quiet"])
        assert proc.returncode == 0, (key, proc.stderr)
        images[key] = read_exr(out)[0]
    ref = images["cameras.json"]
    assert ref[..., 3].sum() > 0.5
    for key, img in images.items():
        assert np.abs(img - ref).max() < 1e-6, key


def refused(tmp_path, source, select, *why, inner=""):
    gaussian(tmp_path)
    proc = run([scene(tmp_path, source, select, inner, name="bad.xml"), "-o", tmp_path / "x.exr", "--quiet"])
    assert proc.returncode == 1, proc.stderr
    for w in why:
        assert w in proc.stderr, (w, proc.stderr)
    assert not (tmp_path / "x.exr").exists()
    return proc.stderr


@pytest.mark.skipif(not shutil.which("colmap"), reason="COLMAP (Debian's colmap, scripts/install-deps.sh) not installed")
def test_models_colmap_itself_wrote_give_the_same_poses(tmp_path, sources):
    """COLMAP's own writers (Debian's colmap 3.8, `model_converter`): our text model written back as
    binary, our binary model as text (17 digits, its comment lines); each exports cameras.json's poses."""
    want = export(tmp_path, scene(tmp_path, "cameras.json", 'image="B.png"', name="want.xml"))
    for src, kind in (("txt", "BIN"), ("bin", "TXT")):
        (tmp_path / src / f"points3D.{src}").write_bytes(b"# 3D point list\n" if src == "txt" else b"\0" * 8)
        out = tmp_path / f"colmap-{kind}"
        out.mkdir()
        proc = subprocess.run(["colmap", "model_converter", "--input_path", tmp_path / src, "--output_path", out,
                               "--output_type", kind], capture_output=True, text=True, timeout=60)
        assert proc.returncode == 0 and (out / f"images.{kind.lower()}").is_file(), proc.stderr
        got = export(tmp_path, scene(tmp_path, out.name, 'imageId="7"', name=f"{kind}.xml"))
        for key in ("camera_to_raster", "world_to_camera"):
            a = got["camera"].get(key, got["frames"][0].get(key))
            b = want["camera"].get(key, want["frames"][0].get(key))
            assert np.allclose(a, b, rtol=0, atol=1e-9), (kind, key)


def test_colmap_models_refuse_other_camera_models_by_name(tmp_path):
    write_colmap_binary(tmp_path / "b", *colmap_records("OPENCV", [FX, FY, 48, 32, 0.1, 0, 0, 0]))
    refused(tmp_path, "b", 'image="A.png"', "cameras.bin: camera record 0", "is OPENCV", "image_undistorter")
    cams, imgs = colmap_records("OPENCV", [FX, FY, 48, 32, 0.1, 0, 0, 0])
    write_colmap_text(tmp_path / "t", cams + [(9, "MY_FANCY_LENS", W, H, [1.0, 2.0])], imgs)
    refused(tmp_path, "t", 'image="B.png"', "images.txt:6", "cameras.txt:3) is OPENCV")
    write_colmap_text(tmp_path / "u", [(2, "MY_FANCY_LENS", W, H, [1.0, 2.0])], imgs)
    refused(tmp_path, "u", 'image="B.png"', "is MY_FANCY_LENS, a model COLMAP does not know")


def bin_model(tmp_path, images_bytes=None, cameras_bytes=None):
    d = tmp_path / "m"
    write_colmap_binary(d, *colmap_records())
    if images_bytes:
        (d / "images.bin").write_bytes(images_bytes((d / "images.bin").read_bytes()))
    if cameras_bytes:
        (d / "cameras.bin").write_bytes(cameras_bytes((d / "cameras.bin").read_bytes()))
    return "m"


def test_hostile_colmap_binaries_are_refused_naming_file_and_record(tmp_path):
    refused(tmp_path, bin_model(tmp_path, lambda b: b[:-30]), 'image="A.png"', "images.bin: image record 2",
            "truncated")
    refused(tmp_path, bin_model(tmp_path, lambda b: struct.pack("<Q", 2 ** 63) + b[8:]), 'image="A.png"',
            "images.bin: says 9223372036854775808 images, more than its")
    refused(tmp_path, bin_model(tmp_path, lambda b: b + b"\0"), 'image="A.png"', "1 bytes after the last of its 3")
    refused(tmp_path, bin_model(tmp_path, cameras_bytes=lambda b: b[:12] + struct.pack("<i", 99) + b[16:]),
            'image="A.png"', "cameras.bin: camera record 0", "model id 99")
    # an image's name without its NUL: the name runs into the file's end
    refused(tmp_path, bin_model(tmp_path, lambda b: struct.pack("<Q", 1) + b[8:8 + 64] + b"A.png" * 4),
            'image="A.png"', "image record 0", "no terminating NUL")
    # a quaternion scaled by 1.01: no pose
    refused(tmp_path, bin_model(tmp_path, lambda b: b[:12] + struct.pack("<d", 1.01 * struct.unpack("<d", b[12:20])[0])
                                + b[20:]), 'image="A.png"', "image record 0", "not 1 within 1e-3")
    refused(tmp_path, bin_model(tmp_path, lambda b: b[:68] + struct.pack("<i", 9) + b[72:]), 'image="A.png"',
            "images.bin: image record 0: image 3 ('A.png'): its camera 9 is not in")
    refused(tmp_path, bin_model(tmp_path), 'image="D.png"', "images.bin: no image named 'D.png'; it has 3 'A.png'")
    refused(tmp_path, bin_model(tmp_path), 'imageId="4"', "no image of IMAGE_ID 4")
    refused(tmp_path, bin_model(tmp_path), 'index="0"', "'index' selects a row of an LLFF poses_bounds.npy; this "
            "COLMAP model takes 'image' or 'imageId'")
    refused(tmp_path, "nowhere", 'image="A.png"', "nowhere: cannot open")  # not a directory: a cameras.json


def test_a_quaternion_rounded_to_few_digits_is_normalised(tmp_path, sources):
    """A hand-written images.txt with 4-digit quaternions (off unit length by ~1e-4) gives the unit
    quaternion's pose: within 1e-3 of the exact one, as the rounding allows."""
    cams, imgs = colmap_records()
    imgs = [(i, np.round(q, 4), t, c, n) for i, q, t, c, n in imgs]
    write_colmap_text(tmp_path / "r", cams, imgs)
    e = export(tmp_path, scene(tmp_path, "r", 'image="A.png"'))
    assert np.allclose(e["frames"][0]["world_to_camera"][0], expected_world_to_camera(*CAMS["A.png"]), atol=1e-3)


def test_hostile_colmap_text_is_refused_naming_file_and_line(tmp_path):
    cams, imgs = colmap_records()
    write_colmap_text(tmp_path / "t", cams, imgs)
    t = tmp_path / "t" / "images.txt"
    lines = t.read_text().split("\n")
    assert lines[5].endswith(" B.png")  # line 6: three comment lines, A's two lines, then B's
    t.write_text("\n".join(lines[:5] + [lines[5] + " extra"] + lines[6:]))
    refused(tmp_path, "t", 'image="A.png"', "images.txt:6", "words after the name 'B.png'")
    t.write_text("\n".join(lines[:5] + [lines[5].replace(lines[5].split()[1], "nan", 1)] + lines[6:]))
    refused(tmp_path, "t", 'image="A.png"', "images.txt:6", "QW 'nan' is not a finite number")
    t.write_text("\n".join(lines[:7] + [lines[3]] + lines[8:]))  # A's image id in C's place
    refused(tmp_path, "t", 'image="A.png"', "image id 3 appears twice")
    write_colmap_text(tmp_path / "t", [(2, "PINHOLE", W, H, [FX, FY, 48])], imgs)
    refused(tmp_path, "t", 'image="A.png"', "cameras.txt:3", "PINHOLE has 4 parameters, the line 3")
    write_colmap_text(tmp_path / "t", [(2, "PINHOLE", W, H, [0.0, FY, 48, 32])], imgs)
    refused(tmp_path, "t", 'image="A.png"', "cameras.txt:3: camera 2: focal 0", "no usable view")
    write_colmap_text(tmp_path / "t", [(2, "PINHOLE", 70000, H, [FX, FY, 48, 32])], imgs)
    refused(tmp_path, "t", 'image="A.png"', "cameras.txt:3: camera 2 is 70000x64")
    (tmp_path / "e").mkdir()
    refused(tmp_path, "e", 'image="A.png"', "holds neither cameras.bin and images.bin nor cameras.txt")


def npy_bytes(header, data):
    h = header.encode()
    h += b" " * (63 - (10 + len(h)) % 64) + b"\n"
    return b"\x93NUMPY\x01\x00" + struct.pack("<H", len(h)) + h + data


def test_poses_bounds_layouts_numpy_writes_are_read(tmp_path, sources):
    """float32, big-endian and a Fortran-order array (np.save of a transposed array) hold the same poses."""
    want = export(tmp_path, scene(tmp_path, "cameras.json", 'image="B.png"'))["frames"][0]["world_to_camera"][0]
    np.save(tmp_path / "f.npy", np.asfortranarray(llff_rows()))
    assert b"'fortran_order': True" in (tmp_path / "f.npy").read_bytes()[:128]
    got = export(tmp_path, scene(tmp_path, "f.npy", 'index="1"'))["frames"][0]["world_to_camera"][0]
    assert np.allclose(got, want, rtol=0, atol=1e-12)
    np.save(tmp_path / "s.npy", llff_rows().astype(np.float32))
    got = export(tmp_path, scene(tmp_path, "s.npy", 'index="1"'))["frames"][0]["world_to_camera"][0]
    assert np.allclose(got, want, rtol=0, atol=1e-6)
    np.save(tmp_path / "b.npy", llff_rows().astype(">f8"))
    got = export(tmp_path, scene(tmp_path, "b.npy", 'index="1"'))["frames"][0]["world_to_camera"][0]
    assert np.allclose(got, want, rtol=0, atol=1e-12)


def test_hostile_poses_bounds_are_refused_naming_file_and_row(tmp_path):
    d = tmp_path / "l"
    write_llff(d)
    f, data = d / "poses_bounds.npy", llff_rows().tobytes()
    src = "l/poses_bounds.npy"
    cases = [(b"PK\x03\x04" + data, "not a NumPy .npy file"),
             (npy_bytes("{'descr': '<i8', 'fortran_order': False, 'shape': (3, 17), }", data), "dtype '<i8'"),
             (npy_bytes("{'descr': '<f8', 'fortran_order': False, 'shape': (3, 14), }", data), "shape (3, 14)"),
             (npy_bytes("{'descr': '<f8', 'fortran_order': False, 'shape': (4, 17), }", data), "needs more bytes"),
             (npy_bytes("{'descr': '<f8', 'fortran_order': False, 'shape': (2, 17), }", data), "needs fewer bytes"),
             (npy_bytes("{'descr': '<f8', 'fortran_order': False, 'shape': (18446744073709551615, 17), }", data),
              "needs more bytes"),
             (npy_bytes("{'descr': '<f8', 'fortran_order': False, 'shape': (3, 17), 'x': 1}", data),
              "not the dict numpy writes"),
             (npy_bytes("{'descr': '<f8', 'fortran_order': False, 'shape': (3, 17), }", data)[:200], "truncated"),
             ]
    for content, why in cases:
        f.write_bytes(content)
        refused(tmp_path, src, 'index="0"', "poses_bounds.npy", why)
    bad = llff_rows()
    bad[2, 0:3] *= 1.01  # a scaled world: no rotation
    np.save(f, bad)
    refused(tmp_path, src, 'index="0"', "poses_bounds.npy: row 2", "not a rotation")
    bad = llff_rows()
    bad[1, 9] = 95.5  # a width that is no number of pixels
    np.save(f, bad)
    refused(tmp_path, src, 'index="0"', "row 1", "whole numbers")
    write_llff(d)
    refused(tmp_path, src, 'index="3"', "no row 3 (it has 3, from 0)")
    refused(tmp_path, src, 'image="D.png"', "no image named 'D.png' among its 3 images")
    (d / "images" / "D.png").write_bytes(b"")
    refused(tmp_path, src, 'image="A.png"', "4 images (names ending in JPG, jpg or png) but", "has 3 rows")
    refused(tmp_path, src, 'imageId="1"', "this LLFF file takes 'image' or 'index'")
    refused(tmp_path, src, 'image="A.png" index="1"', "give 'image' or 'index', not both")
    refused(tmp_path, src, 'image="A.png" trainingResolution="2"', "trainingResolution is 3DGS's rule")


def test_a_cameras_json_takes_no_number(tmp_path, sources):
    for attr in ("imageId", "index"):
        refused(tmp_path, "cameras.json", f'{attr}="1"', f"'{attr}' selects", "a cameras.json takes 'image'")
    refused(tmp_path, "cameras.json", 'image="A.png"', "<pose> needs 'image' (an img_name of the file)",
            inner='<animation><pose time="0" image="A.png"/><pose time="1"/></animation>')


def test_a_selector_without_a_source_is_refused(tmp_path):
    gaussian(tmp_path)
    path = tmp_path / "bad.xml"
    path.write_text('<scene>\n<camera position="0 0 -3" lookat="0 0 0" up="0 1 0" image="A.png"/>'
                    '<object name="g"><gaussianModel file="g.ply"/></object></scene>')
    proc = run([path, "-o", tmp_path / "x.exr", "--quiet"])
    assert proc.returncode == 1 and "bad.xml:2" in proc.stderr and "'image' selects a camera" in proc.stderr


def test_the_examples_render_training_views_bit_for_bit(tmp_path):
    """scenes/examples/colmap_views.xml and llff_views.xml hold training_views.xml's two views (as
    TRAJECTORIES.md says): the same seed renders the same image bit for bit."""
    images = []
    for name in ("training_views", "colmap_views", "llff_views"):
        out = tmp_path / f"{name}.exr"
        proc = run([ROOT / "scenes" / "examples" / f"{name}.xml", "--res", "32x24", "--spp", 1, "--tspp", 8,
                    "--seed", 5, "-o", out, "--quiet"])
        assert proc.returncode == 0, (name, proc.stderr)
        images.append(read_exr(out)[0])
    assert images[0][..., 3].sum() > 1
    assert all(np.array_equal(images[0], img) for img in images[1:])
