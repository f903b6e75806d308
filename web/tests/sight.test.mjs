// The 3D view's test of whether the part hides a gate (`blocks`), in Node: against
// three.js's own ray casting on the same meshes, segments in every direction, through a
// turned and scaled node as the GLB's root is.
import { test } from "node:test";
import assert from "node:assert/strict";

import { BoxGeometry, Group, Mesh, MeshBasicMaterial, DoubleSide, Raycaster, TorusKnotGeometry, Vector3 } from "three";

import { blocks } from "../src/viewer.js";

function raycasterBlocks(object, from, to, share) {
  const towards = to.clone().sub(from);
  const length = towards.length();
  const ray = new Raycaster(from, towards.normalize(), 0, length);
  const hit = ray.intersectObject(object, true)[0];
  return hit !== undefined && hit.distance < length * share;
}

test("blocks agrees with three.js's ray casting", () => {
  const material = new MeshBasicMaterial({ side: DoubleSide });
  const root = new Group();
  root.rotation.set(0.3, -1.1, 0.7);
  root.scale.setScalar(0.001);
  const knot = new Mesh(new TorusKnotGeometry(30, 8, 128, 16), material);
  knot.position.set(5, -3, 2);
  root.add(knot);
  // Unindexed too.
  const box = new Mesh(new BoxGeometry(20, 30, 40).toNonIndexed(), material);
  box.position.set(-40, 10, 0);
  root.add(box);
  root.updateMatrixWorld(true);
  let seed = 12345;
  const random = () => ((seed = (seed * 1103515245 + 12345) % 2147483648) / 2147483648) * 2 - 1;
  const point = () => new Vector3(random(), random(), random()).multiplyScalar(0.08);
  let hidden = 0;
  for (let k = 0; k < 400; k++) {
    const [from, to] = [point(), point()];
    for (const share of [0.998, 0.5]) {
      const want = raycasterBlocks(root, from, to, share);
      assert.equal(blocks(root, from, to, share), want, `segment ${k}, share ${share}`);
      hidden += want;
    }
  }
  // Both answers are common.
  assert.ok(hidden > 100 && hidden < 700, `${hidden} of 800 blocked`);
});
