#!/usr/bin/python3
"""src/ is layered: each folder includes only its own folder and the folders
below it (README "Layout"), so the maths at the bottom never depends on a
reader or the renderer above it, and each library has one user folder
(Embree only in accel/, libxml2 only in io/'s scene reader, json-c, OpenEXR
and Assimp only in formats/, OpenImageIO only in io/'s preview). The check
parses every #include of src/ and is tried on planted violations, so it can
fail."""
import os
import re
import pathlib

ROOT = pathlib.Path(__file__).resolve().parent.parent
# bottom to top
# formats/ (readers and writers of PLY, .anim, TUM, cameras.json,
# transforms.json, EXR, meshes) sits below scene/ and render/: a format fills
# the models of surfels/, gaussians/ and motion/, never a scene or a render,
# so the scene and the renderer may read files (issue 50 item 3); only scene
# assembly (the scene XML) and the render's outputs stay in io/ at the top
# splat/ (the thesis's splatting comparands) sits on render/: it blends
# and shades with render/shade.h, the ray tracer's own Phong, and the
# scene reader and output writers of io/ and the commands of cmd/ sit on it;
# api/ (librefrender.so, the Python package's) runs the render command
LAYERS = ['core', 'motion', 'surfels', 'gaussians', 'formats', 'scene', 'accel', 'render', 'splat', 'io', 'cmd',
          'api']
# a system library and the one folder that may include it
LIBRARY_OWNER = {'embree3/': 'accel', 'libxml/': 'io', 'openexr.h': 'formats', 'OpenImageIO/': 'io',
                 'json-c/': 'formats', 'assimp/': 'formats'}
# make bench measures refrender against Embree's own disc primitive, so the
# benchmark (and only it) calls Embree directly
LIBRARY_EXCEPTIONS = {('cmd/bench.c', 'embree3/'), ('cmd/bench_gaussian.c', 'embree3/')}


def violations(src):
    found = []
    for path in sorted(pathlib.Path(src).rglob('*')):
        if path.suffix not in ('.c', '.h', '.cpp'):
            continue
        rel = path.relative_to(src)
        if len(rel.parts) != 2 or rel.parts[0] not in LAYERS:
            found.append(f'{rel}: not in a layer folder')
            continue
        here = LAYERS.index(rel.parts[0])
        for n, line in enumerate(path.read_text(errors='replace').splitlines(), 1):
            m = re.match(r'\s*#\s*include\s*([<"])([^>"]+)[>"]', line)
            if not m:
                continue
            name = m.group(2)
            if m.group(1) == '<':
                for lib, owner in LIBRARY_OWNER.items():
                    if name.startswith(lib) and rel.parts[0] != owner \
                            and (str(rel), lib) not in LIBRARY_EXCEPTIONS:
                        found.append(f'{rel}:{n}: includes <{name}>, which only {owner}/ may use')
                continue
            parts = name.split('/')
            if len(parts) != 2 or parts[0] not in LAYERS:
                found.append(f'{rel}:{n}: "{name}" does not name its folder')
            elif not (pathlib.Path(src) / name).exists():
                found.append(f'{rel}:{n}: "{name}" does not exist')
            elif LAYERS.index(parts[0]) > here:
                found.append(f'{rel}:{n}: {rel.parts[0]}/ includes "{name}" from the higher layer {parts[0]}/')
    return found


def test_src_includes_only_lower_layers():
    assert violations(ROOT / 'src') == []


def test_planted_upward_include_is_found(tmp_path):
    for folder, text in [('core', '#include "io/ply.h"\n'), ('io', '#include "core/common.h"\n'),
                         ('motion', '#include <embree3/rtcore.h>\n'),
                         ('splat', '#include "io/ply.h"\n')]:
        (tmp_path / folder).mkdir()
        (tmp_path / folder / 'x.c').write_text(text)
    (tmp_path / 'io' / 'ply.h').write_text('')
    (tmp_path / 'core' / 'common.h').write_text('')
    found = violations(tmp_path)
    assert len(found) == 3, found
    assert 'splat/x.c:1: splat/ includes "io/ply.h" from the higher layer io/' in found
    assert 'core/x.c:1: core/ includes "io/ply.h" from the higher layer io/' in found
    assert any('<embree3/rtcore.h>' in f for f in found)


def test_planted_format_reaching_up_is_found(tmp_path):
    """A format that reaches for the scene or the renderer, or a library
    used outside its folder, is an error; the scene using a format is not."""
    plants = {'formats/up.c': '#include "scene/scene.h"\n#include "render/render.h"\n',
              'formats/lib.c': '#include <json-c/json.h>\n#include <openexr.h>\n#include <libxml/tree.h>\n',
              'io/lib.c': '#include <json-c/json.h>\n',
              'scene/down.c': '#include "formats/ply.h"\n',
              'render/down.c': '#include "formats/exr.h"\n'}
    for name in ('scene/scene.h', 'render/render.h', 'formats/ply.h', 'formats/exr.h'):
        plants[name] = ''
    for name, text in plants.items():
        (tmp_path / name).parent.mkdir(exist_ok=True)
        (tmp_path / name).write_text(text)
    assert sorted(violations(tmp_path)) == [
        'formats/lib.c:3: includes <libxml/tree.h>, which only io/ may use',
        'formats/up.c:1: formats/ includes "scene/scene.h" from the higher layer scene/',
        'formats/up.c:2: formats/ includes "render/render.h" from the higher layer render/',
        'io/lib.c:1: includes <json-c/json.h>, which only formats/ may use']
