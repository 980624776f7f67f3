#!/usr/bin/python3
"""src/ is layered: each folder includes only its own folder and the folders
below it (README "Layout"), so the maths at the bottom never depends on a
reader or the renderer above it, and each library has one user folder
(Embree only in accel/, libxml2 only in scenexml/, json-c, OpenEXR and
Assimp only in formats/, OpenImageIO only in io/'s preview). The check
parses every #include of src/ and is tried on planted violations, so it can
fail."""
import os
import re
import pathlib

ROOT = pathlib.Path(__file__).resolve().parent.parent
# bottom to top; each floor says what it holds (issue 57 item 3):
# surfels/ holds the surfel maths and the k-buffer of a ray's surfel hits
# (pure data); formats/ (readers and writers of PLY, .anim, TUM,
# cameras.json, transforms.json, EXR, meshes) fills the models of surfels/,
# gaussians/ and motion/, never a scene or a render (issue 50 item 3);
# scene/ holds the scene and its shading (blending and Phong of
# scene/shade.h, which the ray tracer and the splatting methods share);
# scenexml/ assembles a scene from its XML and the formats; accel/ traces
# it; splatting/ (the thesis's splatting comparands) sits beside accel/, on the
# scene and its shading and accel's reach rule, below the ray tracer's
# render/; io/ holds the render's outputs; cmd/ the commands; bench/ the
# second program, refrender-bench ('make bench'), which uses none of cmd/;
# api/ (librefrender.so, the Python package's) runs the render command
LAYERS = ['core', 'motion', 'surfels', 'gaussians', 'formats', 'scene', 'scenexml', 'accel', 'splatting', 'render',
          'io', 'cmd', 'api', 'bench']
# a system library and the one folder that may include it
LIBRARY_OWNER = {'embree3/': 'accel', 'libxml/': 'scenexml', 'openexr.h': 'formats', 'OpenImageIO/': 'io',
                 'json-c/': 'formats', 'assimp/': 'formats'}
# make bench measures refrender against Embree's own disc primitive, so the
# benchmark (and only it) calls Embree directly
LIBRARY_EXCEPTIONS = {('bench/bench.c', 'embree3/'), ('bench/bench_gaussian.c', 'embree3/')}


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


# Inside a folder a file may include any other, but no circle: a module (a
# .c, its .h and its _internal.h) never reaches itself again through the
# folder's includes, so each file can be read and changed after the ones it
# uses (issue 57: gaussian.c -> gaussian_dynamic -> gaussian_hit -> gaussian,
# splatting -> volumetric -> frame -> splatting were circles).
KNOWN_CIRCLES = set()


def module_of(folder, path):
    return f'{folder}/{re.sub(r"_internal$", "", pathlib.PurePath(path).stem)}'


def circles(src):
    """Each circle of the modules' includes inside one folder, as 'a -> b -> a'."""
    graph = {}
    for path in sorted(pathlib.Path(src).rglob('*')):
        rel = path.relative_to(src)
        if path.suffix not in ('.c', '.h', '.cpp') or len(rel.parts) != 2:
            continue
        me = module_of(rel.parts[0], path.name)
        uses = graph.setdefault(me, set())
        for line in path.read_text(errors='replace').splitlines():
            m = re.match(r'\s*#\s*include\s*"([^"/]+)/([^"]+)"', line)
            if m and m.group(1) == rel.parts[0] and module_of(m.group(1), m.group(2)) != me:
                uses.add(module_of(m.group(1), m.group(2)))
    found, state = [], {}

    def visit(node, stack):
        state[node] = 'open'
        stack.append(node)
        for nxt in sorted(graph.get(node, ())):
            if state.get(nxt) == 'open':
                found.append(' -> '.join(stack[stack.index(nxt):] + [nxt]))
            elif nxt not in state:
                visit(nxt, stack)
        stack.pop()
        state[node] = 'done'
    for node in sorted(graph):
        if node not in state:
            visit(node, [])
    return found


def test_no_circle_inside_a_folder():
    assert set(circles(ROOT / 'src')) - KNOWN_CIRCLES == set()


def test_planted_circle_is_found(tmp_path):
    plants = {'splatting/a.c': '#include "splatting/a.h"\n#include "splatting/b.h"\n',
              'splatting/a.h': '',
              'splatting/b.c': '#include "splatting/b_internal.h"\n',
              'splatting/b_internal.h': '#include "splatting/c.h"\n',
              'splatting/c.h': '#include "splatting/a.h"\n',
              'splatting/d.c': '#include "splatting/d.h"\n#include "splatting/a.h"\n',
              'core/x.h': '#include "splatting/a.h"\n'}
    for name, text in plants.items():
        (tmp_path / name).parent.mkdir(exist_ok=True)
        (tmp_path / name).write_text(text)
    assert circles(tmp_path) == ['splatting/a -> splatting/b -> splatting/c -> splatting/a']


def test_src_includes_only_lower_layers():
    assert violations(ROOT / 'src') == []


def test_planted_upward_include_is_found(tmp_path):
    for folder, text in [('core', '#include "io/ply.h"\n'), ('io', '#include "core/common.h"\n'),
                         ('motion', '#include <embree3/rtcore.h>\n'),
                         ('splatting', '#include "io/ply.h"\n')]:
        (tmp_path / folder).mkdir()
        (tmp_path / folder / 'x.c').write_text(text)
    (tmp_path / 'io' / 'ply.h').write_text('')
    (tmp_path / 'core' / 'common.h').write_text('')
    found = violations(tmp_path)
    assert len(found) == 3, found
    assert 'splatting/x.c:1: splatting/ includes "io/ply.h" from the higher layer io/' in found
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
        'formats/lib.c:3: includes <libxml/tree.h>, which only scenexml/ may use',
        'formats/up.c:1: formats/ includes "scene/scene.h" from the higher layer scene/',
        'formats/up.c:2: formats/ includes "render/render.h" from the higher layer render/',
        'io/lib.c:1: includes <json-c/json.h>, which only formats/ may use']
