// Playback of recorded motions: the page of `mosyn view`, `mosyn report` and `mosyn compare`
// (the data layout is described in viewer.js).
import * as THREE from 'three';
import { Figure } from './figures.js';
import { Stage } from './stage.js';

export function startPlayback(data) {
  const motions = data.motions;
  const stage = new Stage(document.getElementById('view'));

  const boxes = motions.map((m) => {
    const box = new THREE.Box3();
    for (const f of m.frames) for (let i = 0; i < f.length; i += 3) box.expandByPoint(new THREE.Vector3(f[i], f[i + 1], f[i + 2]));
    return box;
  });
  const floorY = Math.min(0, ...boxes.map((b) => b.min.y));
  const figures = motions.map((m) => {
    const fig = new Figure(m, floorY);
    stage.scene.add(fig.group);
    return fig;
  });

  // Side by side: motions in a near-square grid of cells as large as the largest path, so the
  // scene stays compact however many motions there are.
  function cellOffsets() {
    const cols = Math.ceil(Math.sqrt(motions.length));
    const w = Math.max(1.5, ...boxes.map((b) => b.max.x - b.min.x)) + 1.2;
    const d = Math.max(1.5, ...boxes.map((b) => b.max.z - b.min.z)) + 1.2;
    const rows = Math.ceil(motions.length / cols);
    return boxes.map((b, i) => {
      const col = i % cols, row = Math.floor(i / cols);
      const cx = (col - (cols - 1) / 2) * w, cz = (row - (rows - 1) / 2) * d;
      return new THREE.Vector3(cx - (b.min.x + b.max.x) / 2, 0, cz - (b.min.z + b.max.z) / 2);
    });
  }
  const offsets = cellOffsets();

  const duration = Math.max(0, ...motions.map((m) => (m.frames.length - 1) / m.fps));
  let time = 0;
  let playing = true;
  let speed = 1;
  let follow = -1;  // -1: frame every figure; else the index of the followed motion

  const play = document.getElementById('play');
  const scrub = document.getElementById('scrub');
  const speedSelect = document.getElementById('speed');
  const overlay = document.getElementById('overlay');
  const clock = document.getElementById('clock');
  const cameraSelect = document.getElementById('camera');
  scrub.max = String(duration);
  scrub.step = String(Math.max(duration / 1000, 1e-3));

  function layout() {
    const all = new THREE.Box3();
    figures.forEach((fig, i) => {
      fig.group.position.copy(overlay.checked ? new THREE.Vector3() : offsets[i]);
      const b = boxes[i].clone().translate(fig.group.position);
      all.union(b);
    });
    stage.setGround(all, floorY);
    stage.target = null;  // jump to the new framing
  }

  function framedBox() {
    const box = new THREE.Box3();
    figures.forEach((fig, i) => {
      if (follow < 0 || follow === i) fig.boxAt(fig.frameAt(time), box);
    });
    return box;
  }

  function pose(t) {
    figures.forEach((fig) => fig.pose(fig.frameAt(t)));
    scrub.value = String(t);
    clock.textContent = `${t.toFixed(2)} / ${duration.toFixed(2)} s`;
  }

  function setFollow(k) {
    follow = k >= 0 && k < motions.length ? k : -1;
    cameraSelect.value = String(follow);
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
  cameraSelect.addEventListener('change', () => setFollow(Number(cameraSelect.value)));
  window.addEventListener('resize', () => stage.resize());
  window.addEventListener('keydown', (e) => {
    if (e.code === 'Space') {
      play.click();
      e.preventDefault();
    }
  });

  const legend = document.getElementById('legend');
  motions.forEach((m, i) => {
    const item = document.createElement('span');
    item.className = 'item';
    item.title = 'follow this motion';
    item.innerHTML = `<span class="swatch" style="background:${m.color}"></span>`;
    item.appendChild(document.createTextNode(m.name));
    item.addEventListener('click', () => setFollow(follow === i ? -1 : i));
    legend.appendChild(item);
    const option = document.createElement('option');
    option.value = String(i);
    option.textContent = `follow ${m.name}`;
    cameraSelect.appendChild(option);
  });
  // Many motions side by side are small when all are framed: start by following the first one.
  const hashFollow = /follow=(-?\d+)/.exec(window.location.hash);
  setFollow(hashFollow ? Number(hashFollow[1]) : motions.length > 3 ? 0 : -1);

  let last = null;
  function tick(now) {
    const dt = last === null ? 0 : (now - last) / 1000;
    let looped = false;
    if (last !== null && playing && duration > 0) {
      time += dt * speed;
      looped = time > duration;
      if (looped) time = time % duration;
    }
    last = now;
    pose(time);
    // A loop back to the start is a cut: the camera jumps with it instead of gliding back along
    // the path for a second (which left a followed figure small and off-centre).
    stage.frame(framedBox(), looped ? 0 : dt);
    stage.render();
    document.body.dataset.frameTime = time.toFixed(3);
    requestAnimationFrame(tick);
  }

  stage.resize();
  layout();
  pose(0);
  stage.frame(framedBox(), 0);
  stage.render();
  requestAnimationFrame(tick);
}
