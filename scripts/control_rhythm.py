#!/usr/bin/python3
"""How much gait rhythm a dataset's control carries: per clip, the standard deviation of each
control channel (dx, dz metres/frame, dtheta radians/frame) around its own 1-second moving average,
i.e. what oscillates faster than once a second. Reads a dataset's cache directly (format in
src/data/dataset.h); originals only (no mirrored/reversed copies). Needs python3-numpy.

    scripts/control_rhythm.py DATASET_DIR [--split val]
"""
import argparse, json, os, struct
import numpy as np

def clips(path, pose_dim, control_dim):
    data = open(path, "rb").read()
    assert data[:8] == b"MOSYNCLP", path
    version, pd, cd, n = struct.unpack_from("<IIII", data, 8)
    assert (pd, cd) == (pose_dim, control_dim)
    off = 8 + 16 + 8
    for _ in range(n):
        (slen,) = struct.unpack_from("<I", data, off); off += 4
        source = data[off:off + slen].decode(); off += slen
        content, style, flags, frames = struct.unpack_from("<iiBI", data, off); off += 13
        pose = np.frombuffer(data, np.float32, frames * pd, off).reshape(frames, pd); off += 4 * frames * pd
        ctrl = np.frombuffer(data, np.float32, frames * cd, off).reshape(frames, cd); off += 4 * frames * cd
        yield source, flags, ctrl

ap = argparse.ArgumentParser()
ap.add_argument("dataset")
ap.add_argument("--split", default="val")
a = ap.parse_args()
info = json.load(open(os.path.join(a.dataset, "dataset.json")))
fps = info["fps"]
w = int(round(fps))
res = []
for source, flags, ctrl in clips(os.path.join(a.dataset, a.split + ".bin"), info["layout"]["pose_dim"], info["layout"]["control_dim"]):
    if flags or len(ctrl) < 3 * w:
        continue
    c = ctrl[1:].astype(np.float64)
    kernel = np.ones(w) / w
    trend = np.stack([np.convolve(c[:, k], kernel, mode="valid") for k in range(3)], 1)
    start = (w - 1) // 2
    resid = c[start:start + len(trend)] - trend
    res.append(resid.std(0) * fps)  # per second: m/s and rad/s
r = np.array(res)
print(f"{a.dataset}: {len(r)} clips, root smoothing {info['layout'].get('root_smoothing_s', 0)} s, {fps:g} fps")
print("rhythm (std around the 1-s moving average): dx %.3f m/s, dz %.3f m/s, dtheta %.3f rad/s" % tuple(r.mean(0)))
