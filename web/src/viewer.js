// The 3D view: the GLB that moldgate writes (part coloured by a field, gate discs, centre of
// mass, parting line, qualifying nodes; see crates/moldgate/src/gltf.rs), shown with three.js.
// The file's root node already turns the demolding direction D to +Y and mm to metres.

import {
  Box3,
  CanvasTexture,
  Color,
  DirectionalLight,
  HemisphereLight,
  PerspectiveCamera,
  Raycaster,
  Scene,
  Sphere,
  Sprite,
  SpriteMaterial,
  Vector3,
  WebGLRenderer,
} from "three";
import { GLTFLoader } from "three/examples/jsm/loaders/GLTFLoader.js";
import { OrbitControls } from "three/examples/jsm/controls/OrbitControls.js";

/** The layers of the file a user can hide, by node name (the answer's gates are `gate N`
 * and `gate of body N`; `gate suitability`, the map, is not a gate). */
export const LAYERS = {
  gates: (name) => /^gate (\d+|of body \d+)$/.test(name),
  placed: (name) => name.startsWith("your gate "),
  centre: (name) => name === "centre of mass",
  parting: (name) => name === "parting line",
  qualifying: (name) => name === "qualifying nodes",
};

/** A gate's ring while the part hides it: this opaque. */
const HIDDEN_OPACITY = 0.3;
/** The part hides a gate when the ray to it meets the part this share of the way short of
 * it (the gate's own surface is met at the gate). */
const HIDDEN_SHARE = 0.002;
/** Whether a triangle of `object`'s meshes meets the segment from `from` to `to` (world
 * coordinates) short of `share` of its length, either side of the triangle: the test stops at
 * the first such triangle, over the meshes' own arrays, where three.js's `Raycaster` finds and
 * sorts every hit through an object per triangle (on the 352k-triangle housing about 16 ms a
 * gate in headless Chromium, each time the view rests). */
export function blocks(object, from, to, share) {
  let found = false;
  object.traverse((o) => {
    if (found || !o.isMesh) return;
    // The writer's attributes are plain arrays (no interleaving, no stride).
    const position = o.geometry.attributes.position;
    // The segment in the mesh's own frame: a point at t of the way along it is at t of the
    // way in the world too (the frame is affine).
    const inverse = o.matrixWorld.clone().invert();
    const a = from.clone().applyMatrix4(inverse);
    const d = to.clone().applyMatrix4(inverse).sub(a);
    const p = position.array;
    const index = o.geometry.index?.array;
    const corners = index ? index.length : position.count;
    for (let k = 0; k + 2 < corners; k += 3) {
      const i = 3 * (index ? index[k] : k);
      const j = 3 * (index ? index[k + 1] : k + 1);
      const l = 3 * (index ? index[k + 2] : k + 2);
      // Möller and Trumbore: edges from corner i, the segment's parameter t in (0, share).
      const e1x = p[j] - p[i], e1y = p[j + 1] - p[i + 1], e1z = p[j + 2] - p[i + 2];
      const e2x = p[l] - p[i], e2y = p[l + 1] - p[i + 1], e2z = p[l + 2] - p[i + 2];
      const qx = d.y * e2z - d.z * e2y, qy = d.z * e2x - d.x * e2z, qz = d.x * e2y - d.y * e2x;
      const det = e1x * qx + e1y * qy + e1z * qz;
      if (det === 0) continue;
      const inv = 1 / det;
      const sx = a.x - p[i], sy = a.y - p[i + 1], sz = a.z - p[i + 2];
      const u = (sx * qx + sy * qy + sz * qz) * inv;
      if (!(u >= 0 && u <= 1)) continue;
      const rx = sy * e1z - sz * e1y, ry = sz * e1x - sx * e1z, rz = sx * e1y - sy * e1x;
      const v = (d.x * rx + d.y * ry + d.z * rz) * inv;
      if (!(v >= 0 && u + v <= 1)) continue;
      const t = (e2x * rx + e2y * ry + e2z * rz) * inv;
      if (t > 0 && t < share) {
        found = true;
        return;
      }
    }
  });
  return found;
}

/** How long the view rests before the rings' sight is updated, ms. */
const SIGHT_DELAY_MS = 150;

/** A red ring of constant size on screen around each gate, so a 1 mm gate shows on a 300 mm
 * part; dashed for the own gate of a body the answer's gates do not reach ("gate of body N"). */
function gateRingTexture(dashed = false, label = "") {
  // The ring in the middle of a canvas of 1.5 times its size, with room for its number at
  // the upper right (a layout of several gates).
  const c = document.createElement("canvas");
  c.width = c.height = RING_CANVAS;
  const g = c.getContext("2d");
  const middle = RING_CANVAS / 2;
  g.strokeStyle = "rgb(220, 20, 40)";
  g.lineWidth = 7;
  if (dashed) g.setLineDash([9, 7]);
  g.beginPath();
  g.arc(middle, middle, 26, 0, 2 * Math.PI);
  g.stroke();
  if (label) {
    g.font = "bold 26px sans-serif";
    g.textAlign = "right";
    g.textBaseline = "top";
    g.lineWidth = 5;
    g.setLineDash([]);
    g.strokeStyle = "rgba(255, 255, 255, 0.9)";
    g.strokeText(label, RING_CANVAS - 2, 2);
    g.fillStyle = "rgb(220, 20, 40)";
    g.fillText(label, RING_CANVAS - 2, 2);
  }
  return new CanvasTexture(c);
}

/** A ring's canvas, pixels a side (the ring itself is 64). */
const RING_CANVAS = 96;

export class Viewer {
  constructor(container) {
    this.container = container;
    this.renderer = new WebGLRenderer({ antialias: true });
    this.renderer.setPixelRatio(window.devicePixelRatio || 1);
    this.renderer.setClearColor(new Color(0x2a2f38));
    this.canvas = this.renderer.domElement;
    this.canvas.tabIndex = 0;
    this.canvas.setAttribute("role", "img");
    this.canvas.setAttribute("aria-label", "3D view of the part and its gate");
    container.appendChild(this.canvas);

    this.scene = new Scene();
    this.scene.add(new HemisphereLight(0xffffff, 0x444450, 1.6));
    this.camera = new PerspectiveCamera(35, 1, 0.001, 100);
    this.light = new DirectionalLight(0xffffff, 1.8);
    this.light.position.set(0.3, 0.5, 1);
    this.camera.add(this.light);
    this.scene.add(this.camera);

    this.controls = new OrbitControls(this.camera, this.canvas);
    this.controls.enableDamping = false;
    this.controls.listenToKeyEvents(this.canvas);
    this.controls.addEventListener("change", () => {
      this.render();
      // Whether each gate is in sight, once the view rests (a ray through the whole part
      // for each gate is too slow for every frame of a drag).
      clearTimeout(this.sightTimer);
      this.sightTimer = setTimeout(() => this.updateSight() && this.render(), SIGHT_DELAY_MS);
    });
    this.ringTexture = gateRingTexture();
    this.bodyRingTexture = gateRingTexture(true);
    this.root = null;
    this.visible = { gates: true, placed: true, centre: true, parting: true, qualifying: true };

    // Shift-click on the part places a gate of the designer's: `onPick` gets the point in
    // the part's own frame, mm (the file's root node turns D up and scales to metres).
    this.onPick = null;
    this.canvas.addEventListener("click", (e) => {
      if (!e.shiftKey || !this.onPick) return;
      const p = this.pick(e.clientX, e.clientY);
      if (p) this.onPick(p);
    });

    new ResizeObserver(() => this.resize()).observe(container);
    this.resize();
  }

  resize() {
    const w = Math.max(1, this.container.clientWidth);
    const h = Math.max(1, this.container.clientHeight);
    this.renderer.setSize(w, h, false);
    this.canvas.style.width = "100%";
    this.canvas.style.height = "100%";
    this.camera.aspect = w / h;
    this.camera.updateProjectionMatrix();
    this.render();
  }

  render() {
    this.renderer.render(this.scene, this.camera);
  }

  /** Shows a GLB (bytes); resolves with the file's `asset.extras` once drawn. */
  async show(glb, { keepCamera = false } = {}) {
    // The worker's bytes are a buffer of their own (transferred, not copied): read in place.
    const whole = glb.byteOffset === 0 && glb.byteLength === glb.buffer.byteLength;
    const gltf = await new GLTFLoader().parseAsync(
      whole ? glb.buffer : glb.buffer.slice(glb.byteOffset, glb.byteOffset + glb.byteLength),
      ""
    );
    this.clear();
    this.root = gltf.scene;
    // three.js renames nodes ("gate 1" becomes "gate_1"); the file's own names are kept here.
    const names = gltf.parser.json.nodes.map((n) => n.name);
    this.nodes = new Map();
    const rings = [];
    this.root.traverse((o) => {
      const index = gltf.parser.associations.get(o)?.nodes;
      if (index !== undefined) this.nodes.set(names[index], o);
      if (o.isPoints) {
        o.material.size = 2 * (window.devicePixelRatio || 1);
        o.material.sizeAttenuation = false;
        o.material.transparent = true;
        o.material.opacity = 0.7;
      }
    });
    for (const [name, o] of this.nodes) if (LAYERS.gates(name)) rings.push([name, o]);
    this.scene.add(this.root);
    this.root.updateMatrixWorld(true);
    // Each gate's ring is drawn over the part, so a gate on the far side is still found,
    // but faint while the part hides it (see `updateSight`).
    // Several gates of a layout are numbered as the results list them.
    const numbered = rings.filter(([name]) => /^gate \d+$/.test(name)).length > 1;
    for (const [name, gate] of rings) {
      const number = numbered ? /^gate (\d+)$/.exec(name)?.[1] ?? "" : "";
      const map = number
        ? gateRingTexture(false, number)
        : name.startsWith("gate of body ")
          ? this.bodyRingTexture
          : this.ringTexture;
      const ring = new Sprite(
        new SpriteMaterial({
          map,
          depthTest: false,
          transparent: true,
          sizeAttenuation: false,
        })
      );
      ring.name = `${gate.name} marker`;
      ring.userData.ownTexture = !!number;
      ring.scale.set(0.09, 0.09, 1);
      new Box3().setFromObject(gate).getCenter(ring.position);
      ring.renderOrder = 10;
      this.scene.add(ring);
      this.rings.push(ring);
    }
    this.applyVisibility();
    const part = this.nodes.get("part") || this.root;
    this.bounds = new Box3().setFromObject(part).getBoundingSphere(new Sphere());
    if (!keepCamera) this.reset();
    this.updateSight();
    this.render();
    return gltf.asset.extras || {};
  }

  clear() {
    for (const r of this.rings || []) {
      this.scene.remove(r);
      if (r.userData.ownTexture) r.material.map.dispose();
      r.material.dispose();
    }
    this.rings = [];
    if (this.root) {
      this.scene.remove(this.root);
      this.root.traverse((o) => {
        o.geometry?.dispose();
        o.material?.dispose?.();
      });
      this.root = null;
    }
    this.render();
  }

  setLayer(layer, on) {
    this.visible[layer] = on;
    this.applyVisibility();
    this.render();
  }

  applyVisibility() {
    if (!this.root) return;
    for (const [name, o] of this.nodes) {
      for (const [layer, test] of Object.entries(LAYERS)) {
        if (test(name)) o.visible = this.visible[layer];
      }
    }
    for (const r of this.rings) r.visible = this.visible.gates;
  }

  /** Makes each gate's ring whole when the gate is in sight and faint when the part hides
   * it: the ray from the camera to the gate meets the part more than a sliver before it.
   * True when a ring changed. */
  updateSight() {
    const part = this.nodes?.get("part");
    if (!part || !this.rings.length) return false;
    let changed = false;
    for (const r of this.rings) {
      const hidden = blocks(part, this.camera.position, r.position, 1 - HIDDEN_SHARE);
      const opacity = hidden ? HIDDEN_OPACITY : 1;
      if (r.material.opacity !== opacity) {
        r.material.opacity = opacity;
        changed = true;
      }
      r.userData.hidden = hidden;
    }
    this.container.dataset.gatesHidden = String(this.rings.filter((r) => r.userData.hidden).length);
    return changed;
  }

  /** The point of the part under the pixel (client coordinates), in the part's frame in
   * mm, or null when the pixel shows no part. */
  pick(clientX, clientY) {
    const part = this.nodes?.get("part");
    if (!part || !this.root) return null;
    const box = this.canvas.getBoundingClientRect();
    const ndc = {
      x: ((clientX - box.left) / box.width) * 2 - 1,
      y: -((clientY - box.top) / box.height) * 2 + 1,
    };
    const ray = new Raycaster();
    ray.setFromCamera(ndc, this.camera);
    const hit = ray.intersectObject(part, true)[0];
    if (!hit) return null;
    // The file's root node, `moldgate`, holds the turn to D up and the scale to metres: in
    // its frame the point is the part's own, in mm.
    const frame = this.nodes.get("moldgate") ?? this.root;
    const p = frame.worldToLocal(hit.point.clone());
    return [p.x, p.y, p.z];
  }

  /** Looks at the whole part from `direction` (in view axes: D is +Y). */
  lookFrom(direction, up) {
    if (!this.bounds) return;
    const { center, radius } = this.bounds;
    const distance = radius / Math.sin((this.camera.fov * Math.PI) / 360) * 1.1;
    this.camera.up.copy(up);
    this.camera.position.copy(center).addScaledVector(direction.clone().normalize(), distance);
    this.camera.near = distance / 100;
    this.camera.far = distance * 100;
    this.camera.updateProjectionMatrix();
    this.controls.target.copy(center);
    this.controls.update();
    this.render();
  }

  /** The isometric view with D up. */
  reset() {
    this.lookFrom(new Vector3(1, 0.8, 1.2), new Vector3(0, 1, 0));
  }

  /** Looking along the demolding direction, from the side the mould opens to. */
  viewAlongD() {
    this.lookFrom(new Vector3(0, 1, 0), new Vector3(0, 0, -1));
  }
}
