// Level of detail: the server's octree of a model version's cloud
// (GET /v1/sites/{id}/octree, docs/viewer.md) streamed by what the camera
// sees. Each node holds a spread-out sample of its box and its children the
// rest, so drawing a node and its ancestors shows the box at the node's
// spacing. Every frame the nodes in view are ranked by their size on
// screen and taken, largest first, while the point budget lasts; those not
// yet downloaded are fetched, a few at a time, most important first.

import * as THREE from 'three';

/** Points drawn at most by default: a 0.5-million-point frame's cost. */
export const DEFAULT_POINT_BUDGET = 500_000;
// Downloads in flight at once.
const MAX_LOADS = 4;
// Nodes kept in memory out of view, in points, as a multiple of the budget.
const CACHE_FACTOR = 3;

/**
 * A node's bytes: n float32 x y z, then n uchar r g b, then n uchar support
 * (cloud_octree.h; 0 for sparse points).
 */
export function parseNode(buffer) {
  const count = buffer.byteLength / 16;
  if (!Number.isInteger(count)) throw new Error(`octree node of ${buffer.byteLength} bytes is not whole points`);
  return {
    count,
    positions: new Float32Array(buffer, 0, count * 3),
    colors: new Uint8Array(buffer, count * 12, count * 3),
    support: new Uint8Array(buffer, count * 15, count),
  };
}

/** A tiny max-heap on `priority`. */
class Queue {
  constructor() { this.items = []; }
  get size() { return this.items.length; }
  push(item) {
    const a = this.items;
    a.push(item);
    for (let i = a.length - 1; i > 0;) {
      const up = (i - 1) >> 1;
      if (a[up].priority >= a[i].priority) break;
      [a[up], a[i]] = [a[i], a[up]];
      i = up;
    }
  }
  pop() {
    const a = this.items;
    const top = a[0];
    const last = a.pop();
    if (a.length > 0) {
      a[0] = last;
      for (let i = 0; ;) {
        const l = 2 * i + 1, r = l + 1;
        let best = i;
        if (l < a.length && a[l].priority > a[best].priority) best = l;
        if (r < a.length && a[r].priority > a[best].priority) best = r;
        if (best === i) break;
        [a[best], a[i]] = [a[i], a[best]];
        i = best;
      }
    }
    return top;
  }
}

export class OctreeCloud {
  /**
   * @param {object} options
   * @param {object} options.hierarchy the octree's JSON (its nodes, root first)
   * @param {(name: string, signal: AbortSignal) => Promise<ArrayBuffer>} options.fetchNode
   * @param {THREE.Material} options.material shared by every node
   * @param {() => void} options.onLoad called when a node arrives (render again)
   * @param {(err: Error) => void} [options.onError]
   */
  constructor({ hierarchy, fetchNode, material, onLoad, onError = () => {} }) {
    this.version = hierarchy.version;
    this.cloud = hierarchy.cloud;
    this.totalPoints = hierarchy.points;
    this.fetchNode = fetchNode;
    this.material = material;
    this.onLoad = onLoad;
    this.onError = onError;
    this.budget = DEFAULT_POINT_BUDGET;
    this.group = new THREE.Group();
    this.abort = new AbortController();
    this.loading = 0;
    this.drawnPoints = 0;
    this.loadedPoints = 0;
    this.nodes = hierarchy.nodes.map((n) => ({
      name: n.name,
      points: n.points,
      spacing: n.spacing,
      children: n.children,
      box: new THREE.Box3(new THREE.Vector3(...n.lo), new THREE.Vector3(...n.hi)),
      sphere: null,
      object: null, // THREE.Points once loaded
      state: 'idle', // 'loading' | 'loaded' | 'failed'
      lastVisible: 0,
    }));
    for (const node of this.nodes) node.sphere = node.box.getBoundingSphere(new THREE.Sphere());
    this.frame = 0;
    this.rootReady = this.nodes.length === 0 ? Promise.resolve(null) : this.load(this.nodes[0]);
  }

  /** The root node's points once loaded (a sample of the whole cloud). */
  get root() {
    return this.nodes[0]?.object?.userData.cloud || null;
  }

  /** True when every node the last update wanted is on screen. */
  get settled() {
    return this.loading === 0 && this.wanted === 0;
  }

  /**
   * Chooses the nodes to draw for `camera` on a viewport `heightPx` tall,
   * shows them, hides the rest and starts the downloads they need.
   */
  update(camera, heightPx) {
    this.frame++;
    const frustum = new THREE.Frustum().setFromProjectionMatrix(
      new THREE.Matrix4().multiplyMatrices(camera.projectionMatrix, camera.matrixWorldInverse));
    const eye = camera.getWorldPosition(new THREE.Vector3());
    const scale = heightPx / (2 * Math.tan(THREE.MathUtils.degToRad(camera.fov) / 2));
    const queue = new Queue();
    const wanted = [];
    let drawn = 0;
    if (this.nodes.length > 0) queue.push({ node: this.nodes[0], priority: Infinity });
    while (queue.size > 0) {
      const { node } = queue.pop();
      if (drawn + node.points > this.budget && drawn > 0) break;
      if (node.state !== 'loaded') {
        if (node.state === 'idle') wanted.push(node);
        continue;
      }
      node.lastVisible = this.frame;
      drawn += node.points;
      for (const index of node.children) {
        const child = this.nodes[index];
        if (!frustum.intersectsSphere(child.sphere)) continue;
        const distance = Math.max(child.sphere.center.distanceTo(eye) - child.sphere.radius, 1e-6);
        queue.push({ node: child, priority: (child.sphere.radius * scale) / distance });
      }
    }
    for (const node of this.nodes) {
      if (node.object) node.object.visible = node.lastVisible === this.frame;
    }
    this.drawnPoints = drawn;
    this.wanted = wanted.length;
    for (const node of wanted.slice(0, Math.max(0, MAX_LOADS - this.loading))) this.load(node);
    this.evict();
  }

  load(node) {
    node.state = 'loading';
    this.loading++;
    return this.fetchNode(node.name, this.abort.signal)
      .then((buffer) => {
        const cloud = parseNode(buffer);
        const geometry = new THREE.BufferGeometry();
        geometry.setAttribute('position', new THREE.BufferAttribute(cloud.positions, 3));
        geometry.setAttribute('color', new THREE.BufferAttribute(cloud.colors, 3, true));
        geometry.setAttribute('support', new THREE.BufferAttribute(cloud.support, 1));
        geometry.boundingSphere = node.sphere.clone();
        geometry.boundingBox = node.box.clone();
        node.object = new THREE.Points(geometry, this.material);
        node.object.userData.cloud = cloud;
        node.object.visible = false;
        node.state = 'loaded';
        this.loadedPoints += node.points;
        this.group.add(node.object);
        return cloud;
      })
      .catch((err) => {
        node.state = err?.name === 'AbortError' ? 'idle' : 'failed';
        if (node.state === 'failed') this.onError(err);
        return null;
      })
      .finally(() => {
        this.loading--;
        if (!this.abort.signal.aborted) this.onLoad();
      });
  }

  /** Frees the nodes out of view longest once too many points are held. */
  evict() {
    if (this.loadedPoints <= this.budget * CACHE_FACTOR) return;
    const idle = this.nodes
      .filter((n) => n.object && !n.object.visible && n !== this.nodes[0])
      .sort((a, b) => a.lastVisible - b.lastVisible);
    for (const node of idle) {
      if (this.loadedPoints <= this.budget * CACHE_FACTOR) break;
      this.group.remove(node.object);
      node.object.geometry.dispose();
      node.object = null;
      node.state = 'idle';
      this.loadedPoints -= node.points;
    }
  }

  /** The drawn nodes' Points objects (for picking). */
  visibleObjects() {
    return this.group.children.filter((object) => object.visible);
  }

  dispose() {
    this.abort.abort();
    for (const node of this.nodes) node.object?.geometry.dispose();
    this.group.clear();
  }
}
