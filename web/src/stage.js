// The viewer's stage: camera that frames what moves (all figures, or follows one), a floor that
// catches soft shadows, a grid scaled to the scene, and a sun whose shadow box follows the view.
import * as THREE from 'three';
import { OrbitControls } from 'three/examples/jsm/controls/OrbitControls.js';

// Grid square (metres) for a scene extent: about 10 to 40 squares across.
export function gridStep(extent) {
  for (const step of [0.5, 1, 2, 5, 10, 20, 50]) if (extent / step <= 40) return step;
  return 100;
}

function gridMaterial(step) {
  return new THREE.ShaderMaterial({
    uniforms: { step: { value: step }, minor: { value: new THREE.Color('#c9cdd4') }, major: { value: new THREE.Color('#a9aeb8') } },
    vertexShader: `varying vec3 vWorld;
      void main() {
        vec4 w = modelMatrix * vec4(position, 1.0);
        vWorld = w.xyz;
        gl_Position = projectionMatrix * viewMatrix * w;
      }`,
    fragmentShader: `uniform float step; uniform vec3 minor; uniform vec3 major; varying vec3 vWorld;
      float lines(vec2 c) {
        vec2 g = abs(fract(c - 0.5) - 0.5) / fwidth(c);
        return 1.0 - min(min(g.x, g.y), 1.0);
      }
      void main() {
        vec2 c = vWorld.xz / step;
        float a = lines(c), b = lines(c / 5.0);
        if (max(a, b) <= 0.0) discard;
        gl_FragColor = vec4(b > 0.0 ? major : minor, max(a, b));
      }`,
    transparent: true,
    depthWrite: false,
  });
}

export class Stage {
  constructor(canvas) {
    this.renderer = new THREE.WebGLRenderer({ canvas, antialias: true, preserveDrawingBuffer: true });
    this.renderer.setPixelRatio(window.devicePixelRatio || 1);
    this.renderer.shadowMap.enabled = true;
    this.renderer.shadowMap.type = THREE.PCFShadowMap;
    this.scene = new THREE.Scene();
    this.scene.background = new THREE.Color('#eef0f3');
    this.camera = new THREE.PerspectiveCamera(40, 1, 0.05, 2000);
    this.controls = new OrbitControls(this.camera, canvas);
    this.controls.enableZoom = false;  // the wheel scales the automatic framing instead
    this.controls.enablePan = false;
    this.zoom = 1;
    canvas.addEventListener('wheel', (e) => {
      this.zoom = Math.min(20, Math.max(0.2, this.zoom * (e.deltaY > 0 ? 1.1 : 1 / 1.1)));
      e.preventDefault();
    }, { passive: false });
    this.scene.add(new THREE.HemisphereLight(0xffffff, 0x8a8f99, 1.6));
    this.sun = new THREE.DirectionalLight(0xffffff, 1.8);
    this.sun.castShadow = true;
    this.sun.shadow.mapSize.set(1024, 1024);
    this.sun.shadow.radius = 6;
    this.sun.shadow.bias = -0.0005;
    this.scene.add(this.sun, this.sun.target);
    this.floor = new THREE.Mesh(new THREE.PlaneGeometry(1, 1), new THREE.ShadowMaterial({ opacity: 0.22 }));
    this.floor.rotation.x = -Math.PI / 2;
    this.floor.receiveShadow = true;
    this.scene.add(this.floor);
    this.grid = null;
    this.target = null;     // smoothed centre of what is framed
    this.radius = null;     // smoothed radius of what is framed
    this.camera.position.set(3, 2, 4);
  }

  // Grid and floor covering `box` (the whole scene's paths) at height floorY. The grid is drawn by
  // a shader on a plane (lines from world x, z, anti-aliased by their screen-space width, every
  // fifth darker): long GL lines that pass behind a close camera vanish in SwiftShader.
  setGround(box, floorY) {
    const size = box.getSize(new THREE.Vector3());
    const center = box.getCenter(new THREE.Vector3());
    const extent = Math.max(size.x, size.z, 2) + 4;
    const step = gridStep(extent);
    if (this.grid) {
      this.scene.remove(this.grid);
      this.grid.geometry.dispose();
    }
    const cover = Math.ceil(extent / step) * step;
    this.grid = new THREE.Mesh(new THREE.PlaneGeometry(cover, cover), gridMaterial(step));
    this.grid.rotation.x = -Math.PI / 2;
    this.grid.position.set(Math.round(center.x / step) * step, floorY + 0.001, Math.round(center.z / step) * step);
    this.grid.renderOrder = -1;
    this.scene.add(this.grid);
    this.floor.scale.set(extent * 4, extent * 4, 1);
    this.floor.position.set(center.x, floorY, center.z);
    this.gridStep = step;
  }

  // Frames `box` (what moves now): the target and the distance ease towards it (dt seconds;
  // dt <= 0 jumps), keeping the user's orbit direction.
  frame(box, dt) {
    const center = box.getCenter(new THREE.Vector3());
    const radius = Math.max(box.getSize(new THREE.Vector3()).length() / 2, 1.0);
    const k = dt > 0 ? 1 - Math.exp(-dt * 3) : 1;
    if (!this.target) {  // a fresh framing: the default view direction
      this.target = center.clone();
      this.radius = radius;
      this.controls.target.copy(center);
      this.camera.position.copy(center).add(new THREE.Vector3(1, 1.0, 1.6));
    }
    this.target.lerp(center, k);
    this.radius += (radius - this.radius) * k;
    const dir = this.camera.position.clone().sub(this.controls.target);
    if (dir.lengthSq() < 1e-9) dir.set(1, 1.0, 1.6);
    dir.normalize();
    const fov = (this.camera.fov * Math.PI) / 180;
    const fit = Math.min(fov, fov * this.camera.aspect);
    const distance = (this.radius / Math.sin(fit / 2)) * 0.93 * this.zoom;  // the half-diagonal overstates a body
    this.controls.target.copy(this.target);
    this.camera.position.copy(this.target).addScaledVector(dir, distance);
    this.camera.near = Math.max(0.01, distance / 100);
    this.camera.far = distance * 100;
    this.camera.updateProjectionMatrix();
    // The sun's shadow box follows the view.
    const reach = this.radius * 2.5 + 2;
    this.sun.position.copy(this.target).add(new THREE.Vector3(1, 8, 2).normalize().multiplyScalar(reach * 2));
    this.sun.target.position.copy(this.target);
    const cam = this.sun.shadow.camera;
    cam.left = cam.bottom = -reach;
    cam.right = cam.top = reach;
    cam.near = 0.1;
    cam.far = reach * 5;
    cam.updateProjectionMatrix();
  }

  resize() {
    const canvas = this.renderer.domElement;
    const w = canvas.clientWidth, h = canvas.clientHeight;
    this.renderer.setSize(w, h, false);
    this.camera.aspect = w / Math.max(h, 1);
    this.camera.updateProjectionMatrix();
  }

  render() {
    this.controls.update();
    this.renderer.render(this.scene, this.camera);
  }
}
