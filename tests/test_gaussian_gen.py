"""'refrender gen --gaussians': procedural models written as trained
3DGS/2DGS PLYs, checked with numpy from the official layout alone (the
property list of gaussian_model.py's construct_list_of_attributes, the
activations of load_ply), so the suite can have Gaussian scenes without a
trained model."""
import numpy as np

from conftest import run


def read_ply(path):
    data = path.read_bytes()
    head, _, body = data.partition(b"end_header\n")
    lines = head.decode().splitlines()
    count = int(next(l for l in lines if l.startswith("element vertex")).split()[2])
    names = [l.split()[2] for l in lines if l.startswith("property float")]
    values = np.frombuffer(body, dtype="<f4").reshape(count, len(names))
    return names, {n: values[:, i] for i, n in enumerate(names)}


def test_gen_writes_the_official_layout_with_its_activations(tmp_path):
    for kind, scales in [("2dgs", 2), ("3dgs", 3)]:
        out = tmp_path / f"{kind}.ply"
        proc = run(["gen", "sphere", "--count", 500, "--radius", 2, "--gaussians", kind, "--sh-degree", 2,
                    "-o", out])
        assert proc.returncode == 0, proc.stderr
        names, v = read_ply(out)
        rest = [f"f_rest_{i}" for i in range(24)]  # degree 2: 3 ((2 + 1)^2 - 1)
        assert names == ["x", "y", "z", "nx", "ny", "nz", "f_dc_0", "f_dc_1", "f_dc_2", *rest, "opacity",
                         *[f"scale_{i}" for i in range(scales)], "rot_0", "rot_1", "rot_2", "rot_3"]
        q = np.stack([v[f"rot_{i}"] for i in range(4)], axis=1)
        assert np.allclose(np.linalg.norm(q, axis=1), 1, atol=1e-6)
        assert np.allclose(1 / (1 + np.exp(-v["opacity"])), 0.95, atol=1e-6)
        radius = np.linalg.norm(np.stack([v["x"], v["y"], v["z"]], axis=1), axis=1)
        assert np.allclose(radius, 2, atol=1e-5)  # on the sphere
        # the rotation's third axis (build_rotation's third column) is the sphere's normal
        w, x, y, z = q.T
        third = np.stack([2 * (x * z + w * y), 2 * (y * z - w * x), 1 - 2 * (x * x + y * y)], axis=1)
        normal = np.stack([v["x"], v["y"], v["z"]], axis=1) / radius[:, None]
        assert np.allclose(np.abs((third * normal).sum(axis=1)), 1, atol=1e-5)
        grey = 0.28209479177387814 * np.stack([v[f"f_dc_{c}"] for c in range(3)], axis=1) + 0.5
        assert np.allclose(grey, 0.8, atol=1e-6)  # the default colour


def test_gen_refuses_unknown_kinds_and_degrees(tmp_path):
    proc = run(["gen", "plane", "--gaussians", "4dgs", "-o", tmp_path / "x.ply"])
    assert proc.returncode == 2 and "expected 2dgs or 3dgs" in proc.stderr
    proc = run(["gen", "plane", "--gaussians", "2dgs", "--sh-degree", 4, "-o", tmp_path / "x.ply"])
    assert proc.returncode == 2 and "--sh-degree" in proc.stderr
    assert not (tmp_path / "x.ply").exists()


def test_sh_degree_without_gaussians_is_refused(tmp_path):
    """Regression: `--sh-degree` without `--gaussians` wrote surfels and
    ignored the degree without a word; gen and surfels refuse it."""
    cloud = tmp_path / "c.xyz"
    cloud.write_text("".join(f"{i % 4} {i // 4} 0 0 0 1\n" for i in range(16)))
    for cmd in (["gen", "plane"], ["surfels", cloud]):
        proc = run([*cmd, "--sh-degree", 2, "-o", tmp_path / "x.ply"])
        assert proc.returncode == 2 and "--sh-degree needs --gaussians" in proc.stderr, proc.stderr
        assert not (tmp_path / "x.ply").exists()
