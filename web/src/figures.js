// Solid bodies for the viewer: a capsule per bone (cylinder + joint spheres) in the motion's
// colour, a head, feet coloured while planted, and each motion's ground path. Positions are
// metres, +Y up; a motion's frames are flat [x0, y0, z0, x1, ...] per frame and may grow (live).
import * as THREE from 'three';

// Planted feet: dark, a colour no motion has (motion colours are saturated).
export const PLANTED_COLOR = new THREE.Color('#262626');
const UP = new THREE.Vector3(0, 1, 0);
const cylinder = new THREE.CylinderGeometry(1, 1, 1, 14, 1, true);
const sphere = new THREE.SphereGeometry(1, 16, 12);

// Limb radius (metres, for a 1.7 m body) from the name of the bone's parent joint: trunks thick,
// hands thin; unknown names get an arm's radius.
const RADII = [
  [/spine|chest|hips|pelvis|torso|abdomen|back|root/i, 0.095],
  [/neck/i, 0.05],
  [/shoulder|clavicle|collar/i, 0.055],
  [/up.?leg|thigh|upper.?leg/i, 0.075],
  [/leg|knee|shin|calf/i, 0.055],
  [/foot|ankle|toe/i, 0.04],
  [/hand|wrist|finger|thumb/i, 0.035],
];
function limbRadius(name) {
  for (const [re, r] of RADII) if (re.test(name)) return r;
  return 0.045;
}

// Foot joints: names with foot/ankle/toe, else the two joints lowest on average.
export function footJoints(m) {
  const named = m.names.map((n, j) => (/foot|ankle|toe/i.test(n) ? j : -1)).filter((j) => j >= 0);
  if (named.length) return named;
  const mean = m.names.map((_, j) => m.frames.reduce((s, f) => s + f[3 * j + 1], 0) / m.frames.length);
  return mean.map((h, j) => [h, j]).sort((a, b) => a[0] - b[0]).slice(0, 2).map((x) => x[1]);
}

// planted[t][k]: foot k on the ground at frame t (within 5 cm of its lowest height and slower
// than 0.35 m/s horizontally).
export function plantedFeet(m, feet) {
  const lowest = feet.map((j) => Math.min(...m.frames.map((f) => f[3 * j + 1])));
  return m.frames.map((f, t) => {
    const g = m.frames[Math.min(t + 1, m.frames.length - 1)], p = m.frames[Math.max(t - 1, 0)];
    const dt = Math.max(1, Math.min(t + 1, m.frames.length - 1) - Math.max(t - 1, 0)) / m.fps;
    return feet.map((j, k) => {
      const speed = Math.hypot(g[3 * j] - p[3 * j], g[3 * j + 2] - p[3 * j + 2]) / dt;
      return f[3 * j + 1] - lowest[k] < 0.05 && speed < 0.35;
    });
  });
}

// Height of the body in metres from its first frame (at least 0.5).
function bodyHeight(m) {
  const f = m.frames[0];
  let lo = Infinity, hi = -Infinity;
  for (let i = 1; i < f.length; i += 3) { lo = Math.min(lo, f[i]); hi = Math.max(hi, f[i]); }
  return Math.max(0.5, hi - lo);
}

export class Figure {
  // options.path: draw the motion's ground path (default true; the live page draws trails itself).
  constructor(m, floorY, options = {}) {
    this.motion = m;
    this.group = new THREE.Group();
    this.color = new THREE.Color(m.color);
    this.material = new THREE.MeshStandardMaterial({ color: this.color, roughness: 0.55, metalness: 0.0 });
    this.footMaterial = new THREE.MeshStandardMaterial({ color: PLANTED_COLOR, roughness: 0.5 });
    const scale = bodyHeight(m) / 1.7;
    const radius = m.names.map((n) => limbRadius(n) * scale);
    this.bones = [];
    this.joints = m.names.map((n, j) => {
      // The round end of every bone meeting here: bones j -> child use radius[j].
      const hasChild = m.parents.includes(j);
      const r = Math.max(hasChild ? radius[j] : 0, m.parents[j] >= 0 ? radius[m.parents[j]] : 0, 0.02 * scale);
      return this.addMesh(sphere, r);
    });
    m.parents.forEach((p, c) => {
      if (p >= 0) this.bones.push({ mesh: this.addMesh(cylinder, 1), parent: p, child: c, radius: radius[p] });
    });
    this.head = m.names.findIndex((n) => /head/i.test(n));
    this.headMesh = this.head >= 0 ? this.addMesh(sphere, 0.1 * scale) : null;
    this.feet = footJoints(m);
    this.planted = plantedFeet(m, this.feet);
    this.floorY = floorY;
    this.path = null;
    if (options.path !== false) this.updatePath();
  }

  // Live: makes f the newest frame (the motion keeps the last two) and marks the feet planted
  // against the lowest height each has had so far, with the speed from the previous frame.
  push(f) {
    const m = this.motion;
    const prev = m.frames[m.frames.length - 1];
    m.frames = [prev, f];
    if (!this.lowest) this.lowest = this.feet.map((j) => prev[3 * j + 1]);
    this.feet.forEach((j, k) => { this.lowest[k] = Math.min(this.lowest[k], f[3 * j + 1]); });
    this.planted = [[], this.feet.map((j, k) => {
      const speed = Math.hypot(f[3 * j] - prev[3 * j], f[3 * j + 2] - prev[3 * j + 2]) * m.fps;
      return f[3 * j + 1] - this.lowest[k] < 0.05 && speed < 0.35;
    })];
  }

  addMesh(geometry, r) {
    const mesh = new THREE.Mesh(geometry, this.material);
    mesh.scale.setScalar(r);
    mesh.castShadow = true;
    this.group.add(mesh);
    return mesh;
  }

  // The root's ground path (the root, or its child when the root never moves).
  pathJoint() {
    const m = this.motion;
    if (m.names.length < 2) return 0;
    const f0 = m.frames[0];
    for (const f of m.frames) if (Math.abs(f[0] - f0[0]) + Math.abs(f[2] - f0[2]) > 1e-6) return 0;
    return 1;
  }

  updatePath() {
    const j = this.pathJoint();
    const points = this.motion.frames.map((f) => new THREE.Vector3(f[3 * j], this.floorY + 0.003, f[3 * j + 2]));
    if (this.path) {
      this.group.remove(this.path);
      this.path.geometry.dispose();
    }
    const color = this.color.clone().lerp(new THREE.Color('#000000'), 0.15);
    this.path = new THREE.Line(new THREE.BufferGeometry().setFromPoints(points), new THREE.LineBasicMaterial({ color }));
    this.group.add(this.path);
  }

  frameAt(t) {
    const m = this.motion;
    return Math.min(m.frames.length - 1, Math.max(0, Math.round(t * m.fps)));
  }

  // Poses the body at frame k.
  pose(k) {
    const f = this.motion.frames[k];
    const a = new THREE.Vector3(), b = new THREE.Vector3();
    this.joints.forEach((s, j) => s.position.set(f[3 * j], f[3 * j + 1], f[3 * j + 2]));
    for (const bone of this.bones) {
      a.set(f[3 * bone.parent], f[3 * bone.parent + 1], f[3 * bone.parent + 2]);
      b.set(f[3 * bone.child], f[3 * bone.child + 1], f[3 * bone.child + 2]);
      const length = a.distanceTo(b);
      bone.mesh.visible = length > 1e-6;
      if (!bone.mesh.visible) continue;
      bone.mesh.position.copy(a).add(b).multiplyScalar(0.5);
      bone.mesh.quaternion.setFromUnitVectors(UP, b.sub(a).divideScalar(length));
      bone.mesh.scale.set(bone.radius, length, bone.radius);
    }
    if (this.headMesh) {
      const h = this.head, p = this.motion.parents[h];
      a.set(f[3 * h], f[3 * h + 1], f[3 * h + 2]);
      b.copy(a);
      if (p >= 0) b.sub(new THREE.Vector3(f[3 * p], f[3 * p + 1], f[3 * p + 2])).normalize();
      else b.set(0, 1, 0);
      this.headMesh.position.copy(a).addScaledVector(b, this.headMesh.scale.x * 0.8);
    }
    const planted = this.planted[Math.min(k, this.planted.length - 1)] || [];
    this.feet.forEach((j, i) => {
      const material = planted[i] ? this.footMaterial : this.material;
      this.joints[j].material = material;
      for (const bone of this.bones) if (bone.parent === j) bone.mesh.material = material;
    });
  }

  // Bounding box of the body at frame k, world coordinates (the group's offset included).
  boxAt(k, box) {
    const f = this.motion.frames[k];
    const o = this.group.position;
    for (let i = 0; i < f.length; i += 3) box.expandByPoint(new THREE.Vector3(f[i] + o.x, f[i + 1] + o.y, f[i + 2] + o.z));
    return box;
  }
}
