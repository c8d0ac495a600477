// Live mode of the viewer (`mosyn serve`): characters the server's model animates in real time,
// streamed over a WebSocket to the page's own host (protocol: src/serve/README.md). Arrow keys or
// WASD and a gamepad steer the selected character as a game does, by the velocity and facing they
// ask for relative to the camera (a "stick" message); a style menu (when the model has styles), a
// speed control, add/remove buttons, each character's trail, and a camera that follows the
// selected one. window.mosynLive holds what tests read: frames received, the selected
// character's root per frame with its arrival time, the sticks sent, and key-to-response latencies.
import * as THREE from 'three';
import { Figure } from './figures.js';
import { Stage } from './stage.js';

const KEYS = {
  ArrowUp: ['forward', 1], KeyW: ['forward', 1], ArrowDown: ['forward', -1], KeyS: ['forward', -1],
  ArrowLeft: ['turn', 1], KeyA: ['turn', 1], ArrowRight: ['turn', -1], KeyD: ['turn', -1],
};
const DEADZONE = 0.15;       // gamepad sticks rest a little off centre
const TRAIL_POINTS = 20000;  // ~11 minutes at 30 fps; older points drop off
const MOVED_M = 1e-4;        // a root step this long (per frame) is a response to the input

// A character's trail: the ground path of its root, in a fixed-size buffer.
class Trail {
  constructor(color) {
    this.positions = new Float32Array(TRAIL_POINTS * 3);
    this.count = 0;
    this.geometry = new THREE.BufferGeometry();
    this.geometry.setAttribute('position', new THREE.BufferAttribute(this.positions, 3));
    this.geometry.setDrawRange(0, 0);
    const c = new THREE.Color(color).lerp(new THREE.Color('#000000'), 0.15);
    this.line = new THREE.Line(this.geometry, new THREE.LineBasicMaterial({ color: c }));
    this.line.frustumCulled = false;
  }

  push(root) {
    if (this.count === TRAIL_POINTS) {
      this.positions.copyWithin(0, 3);
      this.count--;
    }
    this.positions.set([root[0], 0.003, root[2]], this.count * 3);
    this.count++;
    this.geometry.setDrawRange(0, this.count);
    this.geometry.attributes.position.needsUpdate = true;
  }
}

// Forward and turn in [-1, 1] from the held keys and the first connected gamepad.
function heldInput(held) {
  let forward = 0, turn = 0;
  for (const code of held) {
    const [axis, sign] = KEYS[code];
    if (axis === 'forward') forward += sign; else turn += sign;
  }
  const pads = navigator.getGamepads ? [...navigator.getGamepads()].filter((p) => p && p.connected) : [];
  if (pads.length) {
    const p = pads[0];
    const dead = (v) => (Math.abs(v) < DEADZONE ? 0 : v);
    const pressed = (i) => (p.buttons[i] && p.buttons[i].pressed ? 1 : 0);
    forward += -dead(p.axes[1] || 0) + pressed(12) - pressed(13);  // left stick / d-pad
    turn += -dead(p.axes[0] || 0) + pressed(14) - pressed(15);
  }
  const clamp = (v) => Math.max(-1, Math.min(1, v));
  return { forward: clamp(forward), turn: clamp(turn) };
}

const el = (id) => document.getElementById(id);

// The live page: connection, characters, controls and the render loop.
class LiveView {
  constructor() {
    this.stage = new Stage(el('view'));
    this.live = { frames: 0, roots: [], sticks: [], latencies: [], errors: [], hello: null, closed: null, frameMs: 0, lagMs: 0 };
    window.mosynLive = this.live;
    this.figures = new Map();  // id -> { fig, trail, style }
    this.hello = null;
    this.selected = 0;
    this.sent = null;       // the last input sent, as a string to compare
    this.press = null;      // a press from standing whose response is being timed
    this.lastRoot = null;
    this.groundAt = null;
    this.held = new Set();  // key codes held down
    // "?render=0": no drawing, to measure the page's network and script path apart from WebGL.
    this.draw = !/[?&]render=0/.test(window.location.search);
    this.ws = new WebSocket(`ws://${window.location.host}/ws`);
    this.ws.onmessage = (e) => this.onMessage(JSON.parse(e.data), performance.now());
    this.ws.onclose = (e) => {
      this.live.closed = { code: e.code, reason: e.reason };
      this.status(`disconnected (${e.code}${e.reason ? ` ${e.reason}` : ''}); reload to reconnect`);
    };
    this.wireControls();
  }

  status(text) { el('status').textContent = text; }

  send(message) { if (this.ws.readyState === WebSocket.OPEN) this.ws.send(JSON.stringify(message)); }

  // The held keys or gamepad as a game steers: a stick relative to the camera (up = away from it)
  // gives the world ground velocity at the speed control's value, and the character faces the way
  // it goes; released, it stops facing where it last went. {vx, vz, facing, moving}.
  stickInput() {
    const input = heldInput(this.held);
    const speed = Number(el('speed').value);
    const ahead = new THREE.Vector3();
    this.stage.camera.getWorldDirection(ahead);
    const f = Math.hypot(ahead.x, ahead.z) > 1e-6 ? { x: ahead.x, z: ahead.z } : { x: 0, z: 1 };
    const n = Math.hypot(f.x, f.z);
    const fx = f.x / n, fz = f.z / n;  // camera forward on the ground; right = (-fz, fx)
    const sx = -input.turn, sy = input.forward;  // the key map's turn (+1 = left) is the stick's -x
    const length = Math.min(1, Math.hypot(sx, sy));
    if (length === 0) return { vx: 0, vz: 0, facing: this.facing || 0, moving: false };
    const dx = sy * fx - sx * fz, dz = sy * fz + sx * fx;
    const d = Math.hypot(dx, dz);
    const vx = (speed * length * dx) / d, vz = (speed * length * dz) / d;
    return { vx, vz, facing: Math.atan2(vx, vz), moving: true };
  }

  // Sends the stick when it changed by more than a little (the camera turns it as it follows),
  // at most 20 times a second unless forced; a press from standing starts a latency measurement
  // from `since` (a key event's own time stamp: when the browser got the key, however busy the
  // page was then).
  sendInput(force, since = performance.now()) {
    if (!this.hello || !this.figures.has(this.selected)) return;
    const stick = this.stickInput();
    const last = this.sent;
    const changed = !last || last.id !== this.selected || Math.abs(stick.vx - last.vx) > 0.02 ||
      Math.abs(stick.vz - last.vz) > 0.02 || Math.abs(stick.facing - last.facing) > 0.02;
    const now = performance.now();
    if (!force && (!changed || (last && stick.moving === last.moving && now - last.at < 50))) return;
    if (stick.moving && (!last || !last.moving)) this.press = { t: since, first: null };
    this.sent = { id: this.selected, ...stick, at: now };
    this.facing = stick.facing;
    this.send({ type: 'stick', character: this.selected, vx: stick.vx, vz: stick.vz, facing: stick.facing });
    this.live.sticks.push([now, stick.vx, stick.vz, stick.facing]);
    if (this.live.sticks.length > 5000) this.live.sticks.splice(0, 1000);
  }

  select(id) {
    if (this.figures.has(this.selected) && id !== this.selected)
      this.send({ type: 'stick', character: this.selected, vx: 0, vz: 0, facing: this.facing || 0 });  // the last one stops
    this.selected = id;
    this.sent = null;
    this.lastRoot = null;
    el('character').value = String(id);
    const entry = this.figures.get(id);
    if (entry && this.hello.styles.length) el('style').value = entry.style || '';
    this.sendInput(true);
  }

  refreshMenu() {
    const menu = el('character');
    menu.innerHTML = '';
    for (const id of [...this.figures.keys()].sort((a, b) => a - b)) {
      const option = document.createElement('option');
      option.value = String(id);
      option.textContent = `character ${id}`;
      option.style.color = this.hello.colors[id];
      menu.appendChild(option);
    }
    menu.value = String(this.selected);
  }

  onMessage(msg, now) {
    if (msg.type === 'hello') this.onHello(msg);
    else if (msg.type === 'frame') this.onFrame(msg, now);
    else if (msg.type === 'added') this.select(msg.character);
    else if (msg.type === 'error') {
      this.live.errors.push(msg.message);
      this.status(`server: ${msg.message}`);
    }
  }

  onHello(msg) {
    this.hello = msg;
    this.live.hello = msg;
    el('speed').max = String(msg.max_speed_mps);
    const styles = el('style');
    styles.innerHTML = '<option value="">any</option>';
    for (const s of msg.styles) {
      const option = document.createElement('option');
      option.value = option.textContent = s;
      styles.appendChild(option);
    }
    el('style-label').style.display = msg.styles.length ? '' : 'none';
  }

  addFigure(c) {
    const h = this.hello;
    const m = { name: `character ${c.id}`, fps: h.fps, color: h.colors[c.id], names: h.joints, parents: h.parents,
      frames: [c.positions.flat()] };
    const entry = { fig: new Figure(m, 0, { path: false }), trail: new Trail(m.color), style: c.style };
    this.stage.scene.add(entry.fig.group, entry.trail.line);
    this.figures.set(c.id, entry);
    this.refreshMenu();
    if (!this.figures.has(this.selected) || this.figures.size === 1) this.select(c.id);
  }

  removeFigure(id) {
    const entry = this.figures.get(id);
    this.stage.scene.remove(entry.fig.group, entry.trail.line);
    this.figures.delete(id);
    this.refreshMenu();
    if (id === this.selected && this.figures.size) this.select(this.figures.keys().next().value);
  }

  // The selected character's root, and the latency of a press: the first frame whose root
  // moved, and the first at half the asked speed.
  track(c, now) {
    const roots = this.live.roots;
    roots.push([now, c.root[0], c.root[2], c.heading]);
    if (roots.length > 5000) roots.splice(0, 1000);
    const press = this.press;
    if (this.lastRoot && press) {
      const step = Math.hypot(c.root[0] - this.lastRoot[0], c.root[2] - this.lastRoot[2]);
      if (press.first === null && step > MOVED_M) press.first = now - press.t;
      if (press.first !== null && step * this.hello.fps >= 0.5 * Number(el('speed').value)) {
        this.live.latencies.push({ first_ms: press.first, half_speed_ms: now - press.t });
        this.press = null;
      }
    }
    this.lastRoot = c.root;
    if (!this.sent || !this.sent.moving) this.facing = c.heading;  // standing: it keeps facing where it does
  }

  onFrame(msg, now) {
    this.live.frames++;
    // How far behind the stream the page is: arrival time against the frame's stream time, above
    // the least seen (a page busy starting up receives a backlog of frames at once).
    const offset = now - msg.time_s * 1000;
    this.minOffset = Math.min(this.minOffset ?? offset, offset);
    this.live.lagMs = offset - this.minOffset;
    const seen = new Set();
    for (const c of msg.characters) {
      seen.add(c.id);
      if (!c.positions) continue;
      const entry = this.figures.get(c.id);
      if (!entry) this.addFigure(c);
      else {
        entry.fig.push(c.positions.flat());
        entry.style = c.style;
      }
      const { fig, trail } = this.figures.get(c.id);
      fig.pose(fig.motion.frames.length - 1);
      trail.push(c.root);
      if (c.id === this.selected) this.track(c, now);
    }
    for (const id of [...this.figures.keys()]) if (!seen.has(id)) this.removeFigure(id);
    const n = this.figures.size;
    const l = this.live.latencies[this.live.latencies.length - 1];
    this.status(`frame ${msg.frame} · ${n} character${n === 1 ? '' : 's'}` +
      (l ? ` · response ${l.first_ms.toFixed(0)} ms (half speed ${l.half_speed_ms.toFixed(0)} ms)` : ''));
  }

  wireControls() {
    window.addEventListener('keydown', (e) => {
      if (!KEYS[e.code]) return;
      e.preventDefault();  // arrows would scroll or move a focused menu
      if (document.activeElement && document.activeElement !== document.body) document.activeElement.blur();
      this.held.add(e.code);
      this.sendInput(false, e.timeStamp);
    });
    window.addEventListener('keyup', (e) => { if (this.held.delete(e.code)) this.sendInput(false); });
    window.addEventListener('blur', () => { this.held.clear(); this.sendInput(false); });  // released elsewhere
    el('speed').addEventListener('input', () => {
      el('speed-value').textContent = `${Number(el('speed').value).toFixed(1)} m/s`;
      this.sendInput(false);
    });
    el('character').addEventListener('change', () => this.select(Number(el('character').value)));
    el('style').addEventListener('change', () =>
      this.send({ type: 'style', character: this.selected, style: el('style').value || null }));
    el('add').addEventListener('click', () => this.send({ type: 'add', style: el('style').value || null }));
    el('remove').addEventListener('click', () => {
      if (this.figures.size > 1) this.send({ type: 'remove', character: this.selected });
    });
    window.addEventListener('resize', () => this.stage.resize());
  }

  // Framed: the selected character (follow) or everyone.
  framedBox() {
    const box = new THREE.Box3();
    for (const [id, { fig }] of this.figures)
      if (!el('follow').checked || id === this.selected) fig.boxAt(fig.motion.frames.length - 1, box);
    if (box.isEmpty()) box.set(new THREE.Vector3(-1, 0, -1), new THREE.Vector3(1, 1.8, 1));
    return box;
  }

  // One animation frame: gamepads polled, the grid moved along with the characters, camera eased.
  tick(now, dt) {
    if (dt > 0) this.live.frameMs += (dt * 1000 - this.live.frameMs) * 0.1;  // the page's own frame time, smoothed
    this.sendInput(false);
    const box = this.framedBox();
    const center = box.getCenter(new THREE.Vector3());
    if (!this.groundAt || Math.hypot(center.x - this.groundAt.x, center.z - this.groundAt.z) > 8) {
      this.groundAt = center.clone();
      this.stage.setGround(new THREE.Box3(center.clone().addScalar(-15), center.clone().addScalar(15)), 0);
    }
    this.stage.frame(box, dt);
    if (this.draw) this.stage.render();
  }
}

export function startLive() {
  const view = new LiveView();
  let last = null;
  const loop = (now) => {
    view.tick(now, last === null ? 0 : (now - last) / 1000);
    last = now;
    requestAnimationFrame(loop);
  };
  view.stage.resize();
  requestAnimationFrame(loop);
}
