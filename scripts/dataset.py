#!/usr/bin/python3
"""refrender dataset: a deblurring benchmark with converged blur, in the layout a method's loader reads.

For every frame of --frames A-B: the motion-blurred image from the converged time integral
(refrender --target-error: EXR with standard errors, 8-bit PNG encoded as its oiio:ColorSpace says,
refrender's own --preview) and the sharp image at the middle of the frame's exposure
(--time at the header's refrender:cameraTime); then the poses and held-out views as the layout's
loader expects, and manifest.json (the noise reached, the blur space, the build, the command).

  llff        poses_bounds.npy (Deblur-NeRF's load_llff.py: N x 17, 3x5 [down right back | t | h w f]
              and near, far), images_1/ (Deblur-NeRF's configs use factor = 1) and images/ (a link
              to it); every --hold-th image from the first (its llffhold) is the sharp view, the
              others blurred, as Deblur-NeRF's synthetic scenes ship.
  nerfstudio  transforms.json (fl_x fl_y cx cy w h, frames' file_path and transform_matrix,
              OpenGL camera-to-world) with train_filenames / val_filenames / test_filenames
              (the dataparser's explicit split: held-out views sharp, the others blurred),
              exposure_time and rolling_shutter_time (3dgs-deblur's keys) and each frame's
              exposure times.

Output is all or nothing: everything is made in DIR.staging and renamed to DIR at the end. A run
stopped (Ctrl-C, a crash) leaves DIR absent; running the same command again keeps every frame
already complete in DIR.staging (its files checked against their SHA-256) and renders the rest.
Several machines sharing a file system can each render a part with --frames C-D --no-assemble
into the same DIR.staging; `--assemble` with the whole range then checks and assembles without
rendering (it names any frame missing). REFRENDER-ARGS after -- go to every render (--res, --spp,
--tspp, --seed, --batches, --max-batches, --pixel-filter, --blur-space, --threads, -D, --shutter)."""
import argparse
import hashlib
import json
import os
import shlex
import shutil
import signal
import socket
import subprocess
import sys
from pathlib import Path

import pydeps

# a missing package: one line, not a traceback; not skimage, which only imagecompare's SSIM
# imports (a third of a second a run, and a dataset runs this script once per part)
pydeps.require("numpy", "scipy", "OpenImageIO")
import numpy as np  # noqa: E402

import imagecompare  # noqa: E402
import safefiles  # noqa: E402

ROOT = Path(__file__).resolve().parent.parent
# Options the dataset sets itself for each render: given after -- they would
# make the renders disagree with the manifest, so they are refused.
OWN_OPTIONS = ("-o", "--output", "--preview", "--frame", "--frames", "--time", "--pass", "--checkpoint",
               "--checkpoint-every", "--resume", "--crop-window", "--target-error", "--quiet")
# Options that change the scene's cameras or times: export needs them too.
SCENE_OPTIONS = ("-D", "--shutter")
FRAME_FILES = ("blur.exr", "blur.png", "sharp.exr", "sharp.png")
NOISE_KEYS = ("stderrMean", "stderrP99", "stderrMax", "stderrReached", "batchesMin", "batchesMax")


class Failure(Exception):
    """A refused input or a failed step: one line for the user."""


def refrender():
    return os.environ.get("REFRENDER", str(ROOT / "build" / "refrender"))


def run(args, what):
    try:
        proc = subprocess.run([refrender(), *map(str, args)], stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                              text=True)
    except OSError as e:
        raise Failure(f"{what}: cannot run {refrender()}: {e.strerror}") from None
    if proc.returncode == 130 or proc.returncode == -signal.SIGINT:
        raise KeyboardInterrupt
    if proc.returncode:
        raise Failure(f"{what}: {proc.stderr.strip() or 'refrender exited with ' + str(proc.returncode)}")
    return proc.stdout


def parse_range(text):
    try:
        a, b = (int(x) for x in text.split("-"))
    except ValueError:
        a, b = 0, -1
    if not 0 <= a <= b:
        raise Failure(f"--frames: expected A-B with 0 <= A <= B, got '{text}'")
    return a, b


def parse_bounds(text):
    try:
        near, far = (float(x) for x in text.split(","))
    except ValueError:
        near = far = float("nan")
    if not 0 < near < far < float("inf"):
        raise Failure(f"--bounds: expected NEAR,FAR with 0 < NEAR < FAR, got '{text}'")
    return near, far


def check_passthrough(extra):
    for word in extra:
        name = word.split("=", 1)[0]
        if name in OWN_OPTIONS:
            raise Failure(f"{word}: set by refrender dataset itself (see --help), not an option to pass after --")


def scene_options(extra):
    """The -D and --shutter pairs of REFRENDER-ARGS (export reads them as the renders do)."""
    out = []
    for i, word in enumerate(extra):
        if word in SCENE_OPTIONS and i + 1 < len(extra):
            out += [word, extra[i + 1]]
        elif word.startswith("--shutter=") or (word.startswith("-D") and len(word) > 2):
            out.append(word)
    return out


def sha256(path):
    h = hashlib.sha256()
    with open(path, "rb") as f:
        for block in iter(lambda: f.read(1 << 20), b""):
            h.update(block)
    return h.hexdigest()


def build_id():
    text = run(["--version"], "refrender --version")
    return text.split("build ", 1)[1].rstrip(")\n") if "build " in text else text.strip()


def export_camera(args, extra, staging_parent):
    """refrender export's JSON of the scene (its inputs_hash, the camera), before any render."""
    path = staging_parent / f".{Path(args.output).name}.export-{os.getpid()}.json"
    try:
        run(["export", args.scene, "--times", 0, "--axes", "opencv", *scene_options(extra), "-o", path],
            "refrender export")
        return json.loads(path.read_text())
    finally:
        if path.exists():
            path.unlink()


def check_llff_camera(fx, fy, cx, cy, width, height, tolerance):
    """LLFF's hwf holds one focal length, and Deblur-NeRF's K puts the principal point at the image
    centre (run_nerf.py, train()): a camera it cannot say is refused."""
    if abs(fx - fy) > tolerance * fx or abs(cx - width / 2) > tolerance * width or \
            abs(cy - height / 2) > tolerance * height:
        raise Failure(f"--layout llff: its hwf holds one focal length and Deblur-NeRF puts the principal point at "
                      f"the image centre, but this camera has fx {fx:.9g}, fy {fy:.9g}, centre ({cx:.9g}, {cy:.9g}) "
                      f"in {width}x{height}: use --layout nerfstudio")


def exported_intrinsics(exported):
    k = np.array(exported["camera"]["camera_to_raster"], dtype=np.float64)  # OpenCV axes
    return k[0, 0], k[1, 1], k[0, 2], k[1, 2]


def identity(args, extra, exported):
    """What makes two runs' frames interchangeable: the scene's bytes and its inputs', the build and
    every setting that reaches a render (not the scene's path, which machines sharing a dataset may
    spell differently, nor the frame range, in which parts of one dataset differ, nor the layout,
    --hold or --bounds, which only the assembly reads)."""
    return {"scene_sha256": sha256(args.scene), "inputs_hash": exported["inputs_hash"],
            "build": build_id(), "target_error": args.target_error, "procedure": args.procedure,
            "refrender_args": extra}


def write_json(path, value):
    safefiles.write_text(path, json.dumps(value, indent=1) + "\n")


def open_staging(staging, ident):
    """The staging directory, made or reused; one made for other settings is refused by name."""
    settings = staging / "settings.json"
    if staging.exists():
        if not settings.is_file():
            raise Failure(f"{staging}: exists but is not a refrender dataset's staging directory (no settings.json)")
        old = json.loads(settings.read_text())
        differ = [k for k in ident if old.get(k) != ident[k]]
        if differ:
            raise Failure(f"{staging}: made with other settings ({', '.join(differ)}: {old.get(differ[0])!r}, now "
                          f"{ident[differ[0]]!r}); remove it or run the command that made it")
        return
    try:
        staging.mkdir()
    except OSError as e:
        if not staging.is_dir():
            raise Failure(f"{staging}: cannot create: {e.strerror}") from None
    write_json(settings, ident)


def frame_dir(staging, frame):
    return staging / "frames" / f"{frame:06d}"


def frame_complete(staging, frame, ident):
    """A frame is kept only if its done.json names these settings and every file's hash matches."""
    d = frame_dir(staging, frame)
    try:
        done = json.loads((d / "done.json").read_text())
        files = done["files"]
        return (done.get("identity") == ident and set(FRAME_FILES) <= set(files)
                and all(sha256(d / n) == files[n] for n in files))
    except (OSError, ValueError, KeyError, TypeError):
        return False


def render_frame(args, extra, staging, frame, ident):
    """Renders one frame into a private directory, renamed into place once complete (so parts
    rendered by several machines, or a run killed half way, never leave half a frame)."""
    final = frame_dir(staging, frame)
    work = final.parent / f"{final.name}.tmp-{socket.gethostname()}-{os.getpid()}"
    shutil.rmtree(work, ignore_errors=True)
    work.mkdir(parents=True)
    common = [args.scene, "--quiet", "--target-error", args.target_error, *extra]
    run([*common, "--frame", frame, "-o", work / "blur.exr", "--preview", work / "blur.png"],
        f"frame {frame}, blurred")
    middle = camera_time(work / "blur.exr")
    render_sharp(common, work, frame, middle)
    if args.procedure:
        render_procedures(args, extra, work, frame)
    write_json(work / "done.json", {"frame": frame, "identity": ident,
                                    "files": {n: sha256(work / n) for n in frame_files(work)}})
    if final.exists():
        shutil.rmtree(final)  # an incomplete frame of an earlier run (frame_complete said so)
    os.rename(work, final)


def camera_time(path):
    return float(imagecompare.read_channels(path, unassociated_alpha=False)[2]["refrender:cameraTime"])


def render_sharp(common, work, frame, middle):
    """The sharp frame at the blurred frame's camera time: --time T centres a rolling shutter's
    lines on T as the exposure centres them on cameraTime (src/TRAJECTORIES.md, the camera's header
    attributes), so both headers' cameraTime must agree; checked."""
    sharp = [w for i, w in enumerate(common) if not (w == "--tspp" or (i and common[i - 1] == "--tspp"))]
    run([*sharp, "--time", repr(middle), "-o", work / "sharp.exr", "--preview", work / "sharp.png"],
        f"frame {frame}, sharp at t = {middle!r}")
    got = camera_time(work / "sharp.exr")
    if abs(got - middle) > 1e-9 * max(1.0, abs(middle)):
        raise Failure(f"frame {frame}: the sharp render's cameraTime {got!r} is not the blurred one's {middle!r}")


def frame_files(work):
    """The files a frame's done.json vouches for: the four images and any procedure's."""
    procs = sorted(str(p.relative_to(work)) for p in (work / "nframe").glob("*")) if (work / "nframe").is_dir() else []
    return [*FRAME_FILES, *procs]


def write_png(exr, png):
    """An 8-bit PNG of a procedure's EXR, as refrender's preview encodes (src/io/preview.c): RGB
    clamped to [0, 1], display values (oiio:ColorSpace sRGB) as they are, linear ones with the sRGB
    curve; in float32, rounded half up."""
    import OpenImageIO as oiio
    ch, _, header = imagecompare.read_channels(exr, unassociated_alpha=False)
    rgb = np.clip(np.stack([ch[c] for c in "RGB"], axis=-1), 0.0, 1.0).astype(np.float32)
    if str(header.get("oiio:ColorSpace", "Linear")).lower() != "srgb":
        rgb = np.where(rgb <= np.float32(0.0031308), np.float32(12.92) * rgb,
                       np.float32(1.055) * np.power(rgb, np.float32(1 / 2.4)) - np.float32(0.055))
    levels = np.floor(rgb * np.float32(255) + np.float32(0.5))  # half up, as preview.c's lroundf
    buf = oiio.ImageBuf(levels.astype(np.uint8))
    if not buf.write(str(png)):
        raise Failure(f"{png}: cannot write: {oiio.geterror()}")


def render_procedures(args, extra, work, frame):
    """Each asked N-frame procedure (scripts/nframe_average.py, its rules and sources) emulated from
    sharp frames within this frame's exposure, beside the true blur: nframe/<name>.exr and .png."""
    scratch = work / "nframe_scratch"
    cmd = [sys.executable, str(Path(__file__).with_name("nframe_average.py")), args.scene, "--reference",
           str(work / "blur.exr"), "--out", str(scratch)]
    for p in args.procedure:
        cmd += ["--procedure", p]
    proc = subprocess.run([*cmd, "--", *[w for w in extra]], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    if proc.returncode in (130, -signal.SIGINT):
        raise KeyboardInterrupt
    if proc.returncode:
        raise Failure(f"frame {frame}, N-frame procedures: {proc.stderr.strip()}")
    (work / "nframe").mkdir()
    for exr in sorted(scratch.glob("procedure_*.exr")):
        name = exr.name[len("procedure_"):]
        os.rename(exr, work / "nframe" / name)
        write_png(work / "nframe" / name, (work / "nframe" / name).with_suffix(".png"))
    shutil.rmtree(scratch)


def render_frames(args, extra, staging, ident, first, last):
    for frame in range(first, last + 1):
        if frame_complete(staging, frame, ident):
            print(f"refrender dataset: frame {frame} already complete in {staging}, kept", file=sys.stderr)
            continue
        if args.assemble:
            raise Failure(f"--assemble: frame {frame} is missing or incomplete in {staging}: render it "
                          f"(refrender dataset ... --frames {frame}-{frame} --no-assemble) first")
        print(f"refrender dataset: frame {frame} ({frame - first + 1}/{last - first + 1})", file=sys.stderr)
        render_frame(args, extra, staging, frame, ident)


def header_intrinsics(header, width, height):
    """fx, fy, cx, cy in pixels from the header's worldToCamera and worldToNDC (Imath M44f, row
    vectors; NDC x = raster x / width from the top-left corner): what the frame was rendered with,
    in float32."""
    w2c = np.array(header["worldToCamera"], dtype=np.float64).reshape(4, 4)
    w2ndc = np.array(header["worldToNDC"], dtype=np.float64).reshape(4, 4)
    cam2ndc = np.linalg.inv(w2c) @ w2ndc

    def raster(x, y):  # a camera-space point at depth 1 (x right, y up, z forward)
        p = np.array([x, y, 1.0, 1.0]) @ cam2ndc
        return p[0] / p[3] * width, p[1] / p[3] * height
    cx, cy = raster(0, 0)
    return raster(1, 0)[0] - cx, cy - raster(0, 1)[1], cx, cy


def intrinsics(exported, header, width, height):
    """The pinhole's fx, fy, cx, cy: export's doubles at the scene's own size, checked against the
    render's header (float32); at another size (--res) the header's."""
    got = header_intrinsics(header, width, height)
    if exported["resolution"] != [width, height]:
        return got
    want = exported_intrinsics(exported)
    if any(abs(a - b) > 1e-5 * max(1.0, abs(b)) for a, b in zip(got, want)):
        raise Failure(f"the render's intrinsics {got} are not export's {want}")
    return want


# OpenCV camera axes (x right, y down, z forward) to OpenGL's (x right, y up, z back)
OPENCV_TO_OPENGL = np.diag([1.0, -1.0, -1.0, 1.0])


def export_scene(args, extra, first, last, staging):
    """Each frame's camera-to-world (OpenGL axes) at the middle of its exposure, its times and
    rolling shutter, and the camera, from refrender export (doubles; scripts/README.md)."""
    path = staging / "export.json"
    run(["export", args.scene, "--frames", f"{first}-{last}", "--times", 1, "--axes", "opencv",
         *scene_options(extra), "-o", path], "refrender export")
    exported = json.loads(path.read_text())
    path.unlink()
    poses = {f["frame"]: {"c2w": np.linalg.inv(np.array(f["world_to_camera"][1])) @ OPENCV_TO_OPENGL,
                          "time": f["times"][1], "open": f["open"], "close": f["close"],
                          "rolling": f["rolling_shutter"]} for f in exported["frames"]}
    return exported, poses


def target_value(text):
    """--target-error in value units (refrender's rule: a trailing 'lv' means 8-bit levels, / 255)."""
    return float(text[:-2]) / 255 if text.endswith("lv") else float(text)


def frame_record(staging, frame, pose, held_out, target):
    d = frame_dir(staging, frame)
    ch, spec, header = imagecompare.read_channels(d / "blur.exr", unassociated_alpha=False)
    if abs(float(header["refrender:cameraTime"]) - pose["time"]) > 1e-9 * max(1.0, abs(pose["time"])):
        raise Failure(f"frame {frame}: the render's cameraTime {header['refrender:cameraTime']} is not export's "
                      f"middle time {pose['time']}")
    noise = {k: header.get(f"refrender:{k}") for k in NOISE_KEYS}
    noise["target_reached"] = bool(float(noise["stderrMax"]) <= target_value(target))
    return {"frame": frame, "split": "test" if held_out else "train", "camera_time": pose["time"],
            "exposure": [pose["open"], pose["close"]], "rolling_shutter": pose["rolling"], "noise": noise,
            "blur": {"exr": f"frames/{d.name}/blur.exr", "png": f"frames/{d.name}/blur.png"},
            "sharp": {"exr": f"frames/{d.name}/sharp.exr", "png": f"frames/{d.name}/sharp.png"},
            "header": header, "size": (spec.width, spec.height)}


def link(src, dst):
    """A hard link (no second copy of the image), else a copy."""
    try:
        os.link(src, dst)
    except OSError:
        shutil.copyfile(src, dst)


def write_llff(staging, records, poses, k, bounds):
    width, height = records[0]["size"]
    fx, fy, cx, cy = k
    check_llff_camera(fx, fy, cx, cy, width, height, 1e-5)  # the header's float32 at another --res
    images = staging / "images_1"
    images.mkdir()
    rows = []
    for r in records:
        link(staging / r["sharp" if r["split"] == "test" else "blur"]["png"], images / f"{r['frame']:06d}.png")
        c2w = poses[r["frame"]]["c2w"]
        right, up, back, t = c2w[:3, 0], c2w[:3, 1], c2w[:3, 2], c2w[:3, 3]
        # LLFF's column order [down, right, back]: load_llff.py turns it into [right, up, back] with
        # poses[:, 1:2], -poses[:, 0:1] (limacv/Deblur-NeRF 9c53976, load_llff_data)
        m = np.stack([-up, right, back, t, [height, width, fx]], axis=1)
        rows.append(np.concatenate([m.ravel(), bounds]))
    os.symlink("images_1", staging / "images")
    with open(staging / "poses_bounds.npy", "wb") as f:
        np.save(f, np.array(rows, dtype=np.float64))


def readout_time(rolling):
    """3dgs-deblur's rolling_shutter_time of export's rolling_shutter: 0 for a global shutter, the
    readout of its own convention; None for the others (lines, gsplat), said per frame only."""
    if rolling["kind"] == "off":
        return 0.0
    return rolling.get("readout_time") if rolling["kind"] == "3dgs-deblur" else None


def write_nerfstudio(staging, records, poses, k):
    width, height = records[0]["size"]
    fx, fy, cx, cy = k
    images = staging / "images"
    images.mkdir()
    frames, split = [], {"train": [], "test": []}
    for r in records:
        name = f"images/frame_{r['frame']:06d}.png"
        link(staging / r["sharp" if r["split"] == "test" else "blur"]["png"], staging / name)
        p = poses[r["frame"]]
        frames.append({"file_path": name, "transform_matrix": p["c2w"].tolist(), "time": p["time"],
                       "exposure_open": p["open"], "exposure_close": p["close"], "rolling_shutter": p["rolling"]})
        split[r["split"]].append(name)
    meta = {"camera_model": "OPENCV", "fl_x": fx, "fl_y": fy, "cx": cx, "cy": cy, "w": width, "h": height,
            "k1": 0.0, "k2": 0.0, "p1": 0.0, "p2": 0.0, "frames": frames, "train_filenames": split["train"],
            "val_filenames": split["test"], "test_filenames": split["test"]}
    first = records[0]
    exposure = first["exposure"][1] - first["exposure"][0]
    if all(abs((r["exposure"][1] - r["exposure"][0]) - exposure) < 1e-12 for r in records):
        meta["exposure_time"] = exposure
    # 3dgs-deblur's rolling_shutter_time is its readout, first line to last (refrender's readoutTime
    # of rolling="3dgs-deblur"); 0 for a global shutter; other conventions only in each frame's own
    readouts = {readout_time(r["rolling_shutter"]) for r in records}
    if len(readouts) == 1 and None not in readouts:
        meta["rolling_shutter_time"] = readouts.pop()
    write_json(staging / "transforms.json", meta)


def manifest(args, records, argv):
    header = records[0]["header"]
    worst = max(float(r["noise"]["stderrMax"]) for r in records)
    return {"tool": "refrender dataset", "command": argv, "build": header.get("refrender:build"),
            "layout": args.layout, "hold": args.hold, "target_error": args.target_error,
            "blur_space": header.get("refrender:blurSpace"), "color_space": header.get("oiio:ColorSpace"),
            "png": "8-bit, refrender's --preview: RGB clamped to [0, 1], encoded as oiio:ColorSpace says",
            "sharp": "--time at refrender:cameraTime, the middle of the frame's exposure",
            "noise_max": worst, "noise_max_8bit_levels": worst * 255,
            "target_reached": all(r["noise"]["target_reached"] for r in records),
            "frames": [{k: v for k, v in r.items() if k not in ("header", "size")} for r in records]}


def assemble(args, extra, staging, ident, first, last, argv):
    for name in ("images", "images_1", "poses_bounds.npy", "transforms.json", "manifest.json"):
        p = staging / name
        if p.is_symlink() or p.is_file():
            p.unlink()
        elif p.is_dir():
            shutil.rmtree(p)  # an assembly interrupted before: made again
    for stale in (staging / "frames").glob("*.tmp-*"):
        shutil.rmtree(stale, ignore_errors=True)
    exported, poses = export_scene(args, extra, first, last, staging)
    # held out: frames 0, H, 2H, ... of the range, as Deblur-NeRF's arange(N)[::llffhold]
    records = [frame_record(staging, f, poses[f], (f - first) % args.hold == 0, args.target_error)
               for f in range(first, last + 1)]
    short = [r["frame"] for r in records if not r["noise"]["target_reached"]]
    if short:
        print(f"refrender dataset: warning: frames {short}: some pixels stayed above --target-error "
              f"{args.target_error} at --max-batches (manifest.json: stderrMax); pass a larger --max-batches "
              "after -- to reach it", file=sys.stderr)
    k = intrinsics(exported, records[0]["header"], *records[0]["size"])
    if args.layout == "llff":
        write_llff(staging, records, poses, k, args.bounds)
    else:
        write_nerfstudio(staging, records, poses, k)
    write_json(staging / "manifest.json", manifest(args, records, argv))


def parse(argv):
    extra = []
    if "--" in argv:
        i = argv.index("--")
        argv, extra = argv[:i], argv[i + 1:]
    p = argparse.ArgumentParser(prog="refrender dataset", description=__doc__.split("\n\n")[0],
                                formatter_class=argparse.RawDescriptionHelpFormatter,
                                epilog="\n\n".join(__doc__.split("\n\n")[1:]))
    p.add_argument("scene")
    p.add_argument("--layout", required=True, choices=("llff", "nerfstudio"))
    p.add_argument("--frames", required=True, help="A-B: the scene's frames A to B (0 <= A <= B)")
    p.add_argument("-o", "--output", required=True, help="the dataset directory (must not exist)")
    p.add_argument("--target-error", default="0.5lv",
                   help="each pixel's largest RGB standard error to reach, in value units or 8-bit levels "
                        "(refrender --target-error; default 0.5lv)")
    p.add_argument("--hold", type=int, default=8, help="every HOLD-th frame from the first is a held-out sharp "
                   "view (Deblur-NeRF's llffhold; default 8)")
    p.add_argument("--bounds", help="NEAR,FAR: the scene's depth range in world units, poses_bounds.npy's last "
                   "two columns (required for --layout llff)")
    p.add_argument("--procedure", action="append", help="also each of these N-frame blur-synthesis procedures "
                   "beside the true blur, frames/N/nframe/NAME.exr and .png (repeatable; the names of "
                   "scripts/nframe_average.py --procedure, e.g. deblur-nerf,bad-gaussians; box a(t) only)")
    p.add_argument("--no-assemble", action="store_true", help="render the frames into DIR.staging and stop (a "
                   "part of a distributed dataset)")
    p.add_argument("--assemble", action="store_true", help="render nothing: check every frame of --frames in "
                   "DIR.staging and assemble DIR")
    p.usage = p.format_usage().split(" ", 1)[1].rstrip() + " [-- REFRENDER-ARGS ...]"
    args = p.parse_args(argv)
    if args.hold < 1:
        p.error("--hold: expected a positive integer")
    if args.assemble and args.no_assemble:
        p.error("--assemble and --no-assemble exclude each other")
    if args.layout == "llff" and not args.bounds:
        p.error("--layout llff needs --bounds NEAR,FAR (poses_bounds.npy's depth range)")
    return args, extra


def stop(signum, frame):
    """SIGTERM (Slurm's, a kill) ends the run as Ctrl-C does: the render running stopped, no DIR."""
    raise KeyboardInterrupt


def main(argv):
    signal.signal(signal.SIGTERM, stop)
    args, extra = parse(argv[1:])
    try:
        first, last = parse_range(args.frames)
        args.bounds = list(parse_bounds(args.bounds)) if args.bounds else None
        check_passthrough(extra)
        safefiles.require_regular(args.scene)
        out = Path(args.output)
        if os.path.lexists(out):
            raise Failure(f"{out}: exists; refrender dataset writes a new directory (remove it or name another)")
        if not out.parent.resolve().is_dir():
            raise Failure(f"{out}: its directory {out.parent} does not exist")
        staging = out.parent / (out.name + ".staging")
        exported = export_camera(args, extra, out.parent)
        if args.layout == "llff":  # before anything renders
            check_llff_camera(*exported_intrinsics(exported), *exported["resolution"], 1e-9)
        ident = identity(args, extra, exported)
        open_staging(staging, ident)
        render_frames(args, extra, staging, ident, first, last)
        if args.no_assemble:
            print(f"refrender dataset: frames {first}-{last} complete in {staging}", file=sys.stderr)
            return 0
        assemble(args, extra, staging, ident, first, last, f"{refrender()} dataset {shlex.join(argv[1:])}")
        if os.path.lexists(out):
            raise Failure(f"{out}: appeared while the dataset was made; the dataset stays in {staging}")
        os.rename(staging, out)
    except (Failure, safefiles.FileRefused, imagecompare.CompareError) as e:
        print(f"refrender dataset: {e}", file=sys.stderr)
        return 1
    except KeyboardInterrupt:
        print("refrender dataset: interrupted; no dataset written (the frames done stay in the staging directory: "
              "the same command continues)", file=sys.stderr)
        return 130
    print(f"refrender dataset: wrote {out}", file=sys.stderr)
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
