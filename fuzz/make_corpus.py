#!/usr/bin/env python3
"""Writes the seed corpora fuzz/corpus/<target>/ from the tests' own inputs (run from the repo root:
python3 fuzz/make_corpus.py). Small files only; the corpora are committed."""
import io, os, re, struct, sys
import numpy as np

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
OUT = os.path.join(ROOT, 'fuzz', 'corpus')
SEP = b'\n--mosyn-fuzz-file--\n'


def put(target, name, data):
    d = os.path.join(OUT, target)
    os.makedirs(d, exist_ok=True)
    with open(os.path.join(d, name), 'wb') as f:
        f.write(data if isinstance(data, bytes) else data.encode())


def cpp_string(source, name):
    """The value of `const std::string <name> = "..." "...";` in a C++ source."""
    m = re.search(r'const std::string ' + name + r' =(.*?);\n', source, re.S)
    parts = re.findall(r'"((?:[^"\\]|\\.)*)"', m.group(1))
    return ''.join(parts).encode().decode('unicode_escape')


# BVH: the tests' four-joint file, a one-joint file, a file with End Sites only, CRLF + tabs.
bvh_test = open(os.path.join(ROOT, 'tests/io/test_bvh.cpp')).read()
small = cpp_string(bvh_test, 'kSmall')
put('bvh', 'small.bvh', small)
put('bvh', 'small_crlf.bvh', small.replace('\n', '\r\n').replace('  ', '\t'))
put('bvh', 'one_joint.bvh', 'HIERARCHY\nROOT Root\n{\nOFFSET 0 0 0\nCHANNELS 6 Xposition Yposition Zposition '
    'Zrotation Xrotation Yrotation\nEnd Site\n{\nOFFSET 0 1 0\n}\n}\nMOTION\nFrames: 3\nFrame Time: 0.0333333\n'
    '0 0 0 0 0 0\n1 2 3 90 45 -30\n1e2 -2.5 .5 +180 -90 720\n')
put('bvh', 'no_frames.bvh', 'HIERARCHY\nROOT Hips\n{\nOFFSET 0 0 0\nCHANNELS 3 Zrotation Yrotation Xrotation\n'
    'JOINT Spine\n{\nOFFSET 0 10 0\nCHANNELS 2 Xrotation Zrotation\n}\n}\nMOTION\nFrames: 0\nFrame Time: 0.01\n')

# NPY: the dtypes and layouts the reader accepts.
for name, arr in [('f4_2x3', np.arange(6, dtype='<f4').reshape(2, 3)), ('f8_vec', np.linspace(0, 1, 5)),
                  ('i4_scalar', np.array(7, dtype='<i4')), ('i8_empty', np.zeros((0, 3), dtype='<i8')),
                  ('f4_fortran', np.asfortranarray(np.arange(6, dtype='<f4').reshape(2, 3))),
                  ('f4_positions', np.zeros((2, 3, 3), dtype='<f4'))]:
    b = io.BytesIO()
    np.save(b, arr)
    put('npy', name + '.npy', b.getvalue())

# CSV: numeric tables, root controls and --path strings.
put('csv', 'control.csv', 'dx,dz,dtheta\n0.01,0.02,0.001\n0.01,0.03,-0.002\n')
put('csv', 'positions.csv', 'frame,Hips.x,Hips.y,Hips.z\n0,0,0.9,0\n1,0.01,0.9,0.02\n')
put('csv', 'comments.csv', '# a comment\r\n\r\nx,y\r\n+1.5e-3,-2\r\n')
put('csv', 'path.txt', '0,0 2,0 2,2,1.5 0,2')
put('csv', 'path_semicolons.txt', '0,0;3,0;3,3')

# JSON: a dataset description and statistics (the tests' small positions dataset).
ds = os.path.join(ROOT, 'tests/models/dataset-positions')
info = open(os.path.join(ds, 'dataset.json'), 'rb').read()
stats = open(os.path.join(ds, 'stats.json'), 'rb').read()
put('json_config', 'dataset.json', info)
put('json_config', 'stats.json', stats)
put('json_config', 'train_config.json', '{"steps": 10, "batch": 4, "lr": 0.001, "window": 20}')


def fnv1a(data):
    h = 1469598103934665603
    for b in data:
        h = ((h ^ b) * 1099511628211) & 0xFFFFFFFFFFFFFFFF
    return h


def tiny_cache(path, clips, frames):
    """The first `clips` clips of a cache, cut to `frames` frames each, re-hashed."""
    b = open(path, 'rb').read()
    pose_dim, control_dim, n = struct.unpack_from('<III', b, 12)
    pos = 8 + 16 + 8
    out_clips = []
    for _ in range(min(n, clips)):
        (slen,) = struct.unpack_from('<I', b, pos); pos += 4
        src = b[pos:pos + slen]; pos += slen
        content, style, flags, nf = struct.unpack_from('<iiBI', b, pos); pos += 13
        pose = b[pos:pos + 4 * nf * pose_dim]; pos += 4 * nf * pose_dim
        ctrl = b[pos:pos + 4 * nf * control_dim]; pos += 4 * nf * control_dim
        k = min(nf, frames)
        out_clips.append(struct.pack('<I', slen) + src + struct.pack('<iiBI', content, style, flags, k) +
                         pose[:4 * k * pose_dim] + ctrl[:4 * k * control_dim])
    head = b'MOSYNCLP' + struct.pack('<IIIIQ', 1, pose_dim, control_dim, len(out_clips),
                                     sum(struct.unpack_from('<I', c, 4 + struct.unpack_from('<I', c, 0)[0] + 9)[0]
                                         for c in out_clips))
    data = head + b''.join(out_clips)
    return data + struct.pack('<Q', fnv1a(data)) + b'MOSYNEND'


train = tiny_cache(os.path.join(ds, 'train.bin'), 2, 8)
val = tiny_cache(os.path.join(ds, 'val.bin'), 1, 8)
info_json = re.sub(rb'"window_frames":\s*\d+', b'"window_frames": 4', info)
info_json = re.sub(rb'"window_hop":\s*\d+', b'"window_hop": 2', info_json)
put('dataset', 'positions.ds', info_json + SEP + stats + SEP + train + SEP + val)
put('dataset', 'no_val.ds', info_json + SEP + stats + SEP + train + SEP + tiny_cache(os.path.join(ds, 'val.bin'), 0, 0))

# Run directories: the tests' small RVAE run (config, stats, checkpoint).
run = os.path.join(ROOT, 'tests/models/rvae')
put('run', 'rvae.run', b''.join([open(os.path.join(run, 'config.json'), 'rb').read(), SEP,
                                 open(os.path.join(run, 'stats.json'), 'rb').read(), SEP,
                                 open(os.path.join(run, 'checkpoint.pt'), 'rb').read()]))
print('corpus written to', OUT)
