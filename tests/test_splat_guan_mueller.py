#!/usr/bin/python3
"""refrender splat guan-mueller against guan_mueller_reference.py, a numpy
reading of Guan and Mueller's motion hints (SPBG 2004) written from the
paper alone, before the C: the sharp object at the shutter's close
composited front to back, one trail per front-facing point (the disk's
screen covariance plus the motion vector's rank-1 one, centred mid-vector),
the trails blended or added, the object over them."""
import numpy as np
import pytest

import guan_mueller_reference as ref
import splat_volumetric_reference as vref
from conftest import run, read_exr

CAMERA = {'position': (0, 0, 4), 'lookat': (0, 0, 0), 'up': (0, 1, 0), 'fov': 40, 'width': 32, 'height': 24}


def scene(splats, shutter=(0.0, 1.0)):
    return {'camera': CAMERA, 'shutter': shutter, 'background': (0.1, 0.2, 0.3), 'epsilon': 0.01, 'sigma': 0.5,
            'splats': splats}


# a tilted splat moving diagonally in depth, a rotating one behind it whose
# trail crosses the first's, and one whose normal faces away (no trail)
HINTS = scene([
    {'center': (-0.4, 0.1, 0), 'normal': (0.2, 0.1, 1), 'radius': 0.25, 'color': (1, 0.5, 0.2),
     'motion': {'kind': 'linear', 'velocity': (0.8, -0.3, 0.4)}},
    {'center': (0.2, -0.1, -0.3), 'normal': (0, 0, 1), 'radius': 0.35, 'color': (0.2, 0.3, 1),
     'motion': {'kind': 'rotation', 'axis': (0, 0, 1), 'center': (0, 0, 0), 'degrees': 40}},
    {'center': (0.3, 0.3, 0.2), 'normal': (0, 0, -1), 'radius': 0.2, 'color': (0.2, 1, 0.3),
     'motion': {'kind': 'linear', 'velocity': (-0.5, 0, 0)}}], shutter=(0.25, 1.0))


def guan_mueller(tmp_path, sc, *args):
    xml = tmp_path / 's.xml'
    xml.write_text(vref.scene_xml(sc))
    out = tmp_path / 'gm.exr'
    proc = run(['splat', 'guan-mueller', xml, *args, '-o', out, '--quiet'])
    assert proc.returncode == 0, proc.stderr
    return read_exr(out)


@pytest.mark.parametrize('trails', ['blend', 'add'])
def test_guan_mueller_equals_the_reference(tmp_path, trails):
    img, hdr = guan_mueller(tmp_path, HINTS, *(['--trails', trails] if trails == 'add' else []))
    want = ref.render(HINTS, trails)
    assert want[..., 3].sum() > 10, 'the object and its trails cover pixels'
    assert np.abs(img - want).max() < 1e-5, np.argwhere(np.abs(img - want).max(-1) >= 1e-5)[:5]
    assert hdr['refrender:method'] == 'guan-mueller'
    assert hdr['refrender:methodParameters'] == f'trails={trails} flash=close'


def test_trails_follow_the_motion_and_only_front_facing_points_leave_one(tmp_path):
    """Independently of the reference: a point moving right leaves a trail
    behind (left of) its sharp disk at the close and none ahead of it; the
    same point with its normal turned away leaves none at all; a still
    point's trail is its own footprint, hidden under the sharp disk, so the
    image is the sharp disk's."""
    moving = {'center': (-0.6, 0, 0), 'normal': (0, 0, 1), 'radius': 0.2, 'color': (1, 1, 1),
              'motion': {'kind': 'linear', 'velocity': (1.2, 0, 0)}}
    img = guan_mueller(tmp_path, scene([moving]))[0][..., 3]
    row = img[12]
    assert row[4:12].max() > 0.05 and row[26:].max() == 0, row  # the disk ends near x = 0.6 at the close: pixel 22
    away = guan_mueller(tmp_path, scene([dict(moving, normal=(0, 0, -1))]))[0][..., 3]
    assert away[12, 4:12].max() == 0 and away.max() > 0.5, away[12]
    still = guan_mueller(tmp_path, scene([dict(moving, motion={'kind': 'linear', 'velocity': (0, 0, 0)})]))[0]
    sharp = guan_mueller(tmp_path, scene([dict(moving, normal=(0, 0, -1), motion={'kind': 'linear',
                                                                                 'velocity': (0, 0, 0)})]))[0]
    assert np.abs(still[..., 3] - (1 - (1 - sharp[..., 3]) ** 2)).max() < 1e-5  # the disk over a copy of itself


@pytest.mark.parametrize('args,message', [
    (['--samples', 3], 'guan-mueller draws the object'), (['--time', 0.5], 'guan-mueller draws the object'),
    (['--trails', 'smear'], "--trails: expected blend or add, got 'smear'")])
def test_guan_mueller_usage_errors(tmp_path, args, message):
    xml = tmp_path / 's.xml'
    xml.write_text(vref.scene_xml(HINTS))
    proc = run(['splat', 'guan-mueller', xml, *args, '-o', tmp_path / 'o.exr'])
    assert proc.returncode == 2 and message in proc.stderr, proc.stderr
    proc = run(['splat', 'accum', xml, '--trails', 'add', '-o', tmp_path / 'o.exr'])
    assert proc.returncode == 2 and '--trails is for guan-mueller' in proc.stderr
    assert not (tmp_path / 'o.exr').exists()
