// mosyn viewer: plays motions written by `mosyn view` in the browser with three.js.
// The page embeds the motions as JSON in <script id="mosyn-data" type="application/json">:
//   {"motions": [{"name", "fps", "color": "#rrggbb", "names": [J], "parents": [J],
//                 "frames": [[x0, y0, z0, x1, ...] per frame]}]}   (metres, +Y up)
// and this file bundled inline (esbuild IIFE), so the page works offline from disk.
import * as THREE from 'three';
import { OrbitControls } from 'three/examples/jsm/controls/OrbitControls.js';

const data = JSON.parse(document.getElementById('mosyn-data').textContent);
const motions = data.motions;

const canvas = document.getElementById('view');
const renderer = new THREE.WebGLRenderer({ canvas, antialias: true, preserveDrawingBuffer: true });
renderer.setPixelRatio(window.devicePixelRatio || 1);
const scene = new THREE.Scene();
scene.background = new THREE.Color('#f4f4f4');
const camera = new THREE.PerspectiveCamera(40, 1, 0.01, 1000);
const controls = new OrbitControls(camera, canvas);
scene.add(new THREE.HemisphereLight(0xffffff, 0x888888, 2.5));
const sun = new THREE.DirectionalLight(0xffffff, 1.5);
sun.position.set(3, 10, 5);
scene.add(sun);

// Layout: side by side along X unless "overlay" is ticked.
const boxes = motions.map((m) => {
  const box = new THREE.Box3();
  for (const f of m.frames) for (let i = 0; i < f.length; i += 3) box.expandByPoint(new THREE.Vector3(f[i], f[i + 1], f[i + 2]));
  return box;
});
const spacing = Math.max(1.0, ...boxes.map((b) => b.max.x - b.min.x)) + 1.0;
const offsets = motions.map((m, i) => (i - (motions.length - 1) / 2) * spacing);

const floorY = Math.min(0, ...boxes.map((b) => b.min.y));
const unit = new THREE.Vector3(0, 1, 0);
const boneGeometry = new THREE.CylinderGeometry(1, 1, 1, 10);
const jointGeometry = new THREE.SphereGeometry(1, 12, 8);

// The joint whose ground path is drawn: the root, or its child when the root never moves.
function pathJoint(m) {
  if (m.names.length < 2) return 0;
  const f0 = m.frames[0];
  for (const f of m.frames) if (Math.abs(f[0] - f0[0]) + Math.abs(f[1] - f0[1]) + Math.abs(f[2] - f0[2]) > 1e-6) return 0;
  return 1;
}

// One bone thickness for all figures, from the tallest, so that figures compare.
const boneRadius = 0.01 * Math.max(0.5, ...boxes.map((b) => b.max.y - b.min.y));

const figures = motions.map((m, i) => {
  const group = new THREE.Group();
  scene.add(group);
  const color = new THREE.Color(m.color);
  const material = new THREE.MeshBasicMaterial({ color });
  const bones = [];
  const joints = [];
  const radius = boneRadius;
  for (let j = 0; j < m.parents.length; ++j) {
    const sphere = new THREE.Mesh(jointGeometry, material);
    sphere.scale.setScalar(radius * 1.6);
    group.add(sphere);
    joints.push(sphere);
    if (m.parents[j] >= 0) {
      const bone = new THREE.Mesh(boneGeometry, material);
      group.add(bone);
      bones.push({ mesh: bone, child: j, parent: m.parents[j], radius });
    }
  }
  const pj = pathJoint(m);
  const points = m.frames.map((f) => new THREE.Vector3(f[3 * pj], floorY + 0.002, f[3 * pj + 2]));
  const path = new THREE.Line(
    new THREE.BufferGeometry().setFromPoints(points),
    new THREE.LineBasicMaterial({ color: color.clone().lerp(new THREE.Color('#ffffff'), 0.4) }),
  );
  group.add(path);
  return { group, bones, joints };
});

let grid = null;

const duration = Math.max(0, ...motions.map((m) => (m.frames.length - 1) / m.fps));
let time = 0;
let playing = true;
let speed = 1;

const play = document.getElementById('play');
const scrub = document.getElementById('scrub');
const speedSelect = document.getElementById('speed');
const overlay = document.getElementById('overlay');
const clock = document.getElementById('clock');
scrub.max = String(duration);
scrub.step = String(Math.max(duration / 1000, 1e-3));

function layout() {
  const all = new THREE.Box3();
  figures.forEach((fig, i) => {
    fig.group.position.x = overlay.checked ? 0 : offsets[i];
    const b = boxes[i].clone();
    b.min.x += fig.group.position.x;
    b.max.x += fig.group.position.x;
    all.union(b);
  });
  const size = all.getSize(new THREE.Vector3());
  const center = all.getCenter(new THREE.Vector3());
  const extent = Math.max(size.x, size.z, 2) + 2;
  if (grid) {
    scene.remove(grid);
    grid.geometry.dispose();
  }
  const divisions = Math.min(200, Math.ceil(extent / 0.5));
  grid = new THREE.GridHelper(divisions * 0.5, divisions, 0xbbbbbb, 0xdddddd);
  grid.position.set(Math.round(center.x * 2) / 2, floorY, Math.round(center.z * 2) / 2);
  scene.add(grid);
  const radius = Math.max(size.length() / 2, 1);
  controls.target.copy(center);
  const dir = new THREE.Vector3(1, 0.6, 1.4).normalize();
  camera.position.copy(center).addScaledVector(dir, radius / Math.tan((camera.fov * Math.PI) / 360) * 0.85);
  camera.near = radius / 100;
  camera.far = radius * 100;
  camera.updateProjectionMatrix();
  controls.update();
}

const a = new THREE.Vector3();
const b = new THREE.Vector3();
function pose(t) {
  motions.forEach((m, i) => {
    const frame = m.frames[Math.min(m.frames.length - 1, Math.max(0, Math.round(t * m.fps)))];
    const fig = figures[i];
    for (let j = 0; j < fig.joints.length; ++j) fig.joints[j].position.set(frame[3 * j], frame[3 * j + 1], frame[3 * j + 2]);
    for (const bone of fig.bones) {
      a.set(frame[3 * bone.parent], frame[3 * bone.parent + 1], frame[3 * bone.parent + 2]);
      b.set(frame[3 * bone.child], frame[3 * bone.child + 1], frame[3 * bone.child + 2]);
      const length = a.distanceTo(b);
      bone.mesh.visible = length > 1e-9;
      if (!bone.mesh.visible) continue;
      bone.mesh.position.copy(a).add(b).multiplyScalar(0.5);
      bone.mesh.quaternion.setFromUnitVectors(unit, b.sub(a).divideScalar(length));
      bone.mesh.scale.set(bone.radius, length, bone.radius);
    }
  });
  scrub.value = String(t);
  clock.textContent = `${t.toFixed(2)} / ${duration.toFixed(2)} s`;
}

function resize() {
  const w = canvas.clientWidth;
  const h = canvas.clientHeight;
  renderer.setSize(w, h, false);
  camera.aspect = w / Math.max(h, 1);
  camera.updateProjectionMatrix();
}

play.addEventListener('click', () => {
  playing = !playing;
  play.textContent = playing ? 'Pause' : 'Play';
});
scrub.addEventListener('input', () => {
  time = Number(scrub.value);
  pose(time);
});
speedSelect.addEventListener('change', () => {
  speed = Number(speedSelect.value);
});
overlay.addEventListener('change', layout);
window.addEventListener('resize', resize);
window.addEventListener('keydown', (e) => {
  if (e.code === 'Space') {
    play.click();
    e.preventDefault();
  }
});

const legend = document.getElementById('legend');
motions.forEach((m) => {
  const item = document.createElement('span');
  item.className = 'item';
  item.innerHTML = `<span class="swatch" style="background:${m.color}"></span>`;
  item.appendChild(document.createTextNode(m.name));
  legend.appendChild(item);
});

let last = null;
function tick(now) {
  if (last !== null && playing && duration > 0) {
    time += ((now - last) / 1000) * speed;
    if (time > duration) time = time % duration;
  }
  last = now;
  pose(time);
  controls.update();
  renderer.render(scene, camera);
  document.body.dataset.frameTime = time.toFixed(3);
  requestAnimationFrame(tick);
}

resize();
layout();
pose(0);
renderer.render(scene, camera);
requestAnimationFrame(tick);
