// Test probe for exported glTF files (tests/render/test_gltf_browser.cpp): loads a .glb with
// three.js's GLTFLoader in the browser, plays each animation with an AnimationMixer and writes the
// world position of every named node at the requested times as JSON into <pre id="result">:
//   {"skinned_meshes": N, "animations": [{"name", "duration", "samples": [{"time", "nodes": {name: [x, y, z]}}]}]}
// or "error: ..." when loading fails. The page holds the file as base64 in
// <script id="mosyn-glb" type="application/octet-stream" data-times="[t0, t1, ...]">.
import * as THREE from 'three';
import { GLTFLoader } from 'three/examples/jsm/loaders/GLTFLoader.js';

const source = document.getElementById('mosyn-glb');
const out = document.getElementById('result');
const times = JSON.parse(source.dataset.times);
const bytes = Uint8Array.from(atob(source.textContent.trim()), (c) => c.charCodeAt(0));

function sample(gltf, clip) {
  const mixer = new THREE.AnimationMixer(gltf.scene);
  const action = mixer.clipAction(clip);
  action.play();
  const samples = [];
  for (const t of times) {
    mixer.setTime(t);
    gltf.scene.updateMatrixWorld(true);
    const nodes = {};
    gltf.scene.traverse((o) => {
      if (!o.name) return;
      const p = o.getWorldPosition(new THREE.Vector3());
      nodes[o.name] = [p.x, p.y, p.z];
    });
    samples.push({ time: t, nodes });
  }
  action.stop();
  mixer.uncacheRoot(gltf.scene);
  return { name: clip.name, duration: clip.duration, samples };
}

new GLTFLoader().parse(
  bytes.buffer,
  '',
  (gltf) => {
    let skinned = 0;
    gltf.scene.traverse((o) => {
      if (o.isSkinnedMesh) skinned += 1;
    });
    const result = { skinned_meshes: skinned, animations: gltf.animations.map((clip) => sample(gltf, clip)) };
    out.textContent = JSON.stringify(result);
  },
  (error) => {
    out.textContent = `error: ${error && error.message ? error.message : error}`;
  },
);
