// The textured mesh (docs/mesh.md) streamed by level of detail: the
// server's listing of a model version's mesh tiles (GET
// /v1/sites/{id}/mesh, docs/api.md), each with its levels (finest first,
// each with its geometric error in metres) as GLBs. Every frame each tile
// wants the coarsest level whose error, projected to the screen at the
// tile's distance, is below a few pixels; a tile shows its coarsest level
// first and a finer one once it has arrived. The GLBs are in the site
// frame (z up) like the points, so they are drawn as they are.

import * as THREE from 'three';
import { GLTFLoader } from 'three/addons/loaders/GLTFLoader.js';

/** A level is fine enough when its error covers at most this many pixels. */
export const MESH_ERROR_PX = 2;
// Downloads in flight at once.
const MAX_LOADS = 4;

function disposeObject(object) {
  object.traverse((child) => {
    if (!child.isMesh) return;
    child.geometry.dispose();
    for (const material of [].concat(child.material)) {
      material.map?.dispose();
      material.dispose();
    }
  });
}

/**
 * The photos' texels are sRGB bytes meant to be shown as they are, as the
 * points' colours are (scene.js turns colour management off): no decoding
 * to linear on the GPU.
 */
function showBytesAsTheyAre(object) {
  object.traverse((child) => {
    if (!child.isMesh) return;
    for (const material of [].concat(child.material)) {
      if (material.map) {
        material.map.colorSpace = THREE.NoColorSpace;
        material.map.needsUpdate = true;
      }
    }
  });
}

/**
 * A GLTFLoader whose embedded images load through an <img> element
 * (TextureLoader) rather than fetch() and createImageBitmap: GLTFLoader
 * hands either a blob: URL of the image's bytes, and the pages' Content
 * Security Policy lets images, not connections, read blob: URLs.
 */
function makeLoader() {
  const loader = new GLTFLoader();
  loader.register((parser) => {
    parser.textureLoader = new THREE.TextureLoader(parser.options.manager);
    return { name: 'arscout_img_textures' };
  });
  return loader;
}

/** The level to draw: the finest loaded at or coarser than `target`, else a finer one loaded. */
function loadedLevel(levels, target) {
  for (let l = target; l < levels.length; l++) if (levels[l].object) return l;
  for (let l = target - 1; l >= 0; l--) if (levels[l].object) return l;
  return -1;
}

export class MeshTiles {
  /**
   * @param {object} options
   * @param {object} options.listing GET /v1/sites/{id}/mesh's JSON
   * @param {(url: string, signal: AbortSignal) => Promise<ArrayBuffer>} options.fetchLevel
   * @param {() => void} options.onLoad called when a level arrives (render again)
   * @param {(err: Error) => void} [options.onError]
   * @param {MeshTiles} [options.previous] the last version's mesh: its
   *   levels whose blobs this version keeps are taken over, not fetched again
   */
  constructor({ listing, fetchLevel, onLoad, onError = () => {}, previous = null }) {
    this.version = listing.version;
    this.totalTriangles = listing.triangles;
    this.fetchLevel = fetchLevel;
    this.onLoad = onLoad;
    this.onError = onError;
    this.errorPx = MESH_ERROR_PX;
    this.group = new THREE.Group();
    this.group.name = 'mesh';
    this.abort = new AbortController();
    this.loader = makeLoader();
    this.loading = 0;
    this.wanted = 0;
    this.drawnTriangles = 0;
    const kept = previous ? previous.takeLevels() : new Map();
    this.tiles = listing.tiles.map((t) => {
      const box = new THREE.Box3(new THREE.Vector3(...t.lo), new THREE.Vector3(...t.hi));
      const levels = t.levels.map((l) => ({
        url: l.url,
        blob: l.blob,
        error: l.error,
        triangles: l.triangles,
        object: kept.get(l.blob) || null,
        state: kept.has(l.blob) ? 'loaded' : 'idle',
      }));
      for (const level of levels) if (level.object) this.group.add(level.object);
      return { name: t.tile, box, sphere: box.getBoundingSphere(new THREE.Sphere()), levels, shown: -1 };
    });
    for (const object of kept.values()) if (!object.parent) disposeObject(object);
  }

  /** True when every level the last update wanted is on screen. */
  get settled() {
    return this.loading === 0 && this.wanted === 0;
  }

  /** Tiles showing a level. */
  get shownTiles() {
    return this.tiles.filter((t) => t.shown >= 0).length;
  }

  /**
   * Chooses each tile's level for `camera` on a viewport `heightPx` tall,
   * shows the best one loaded, and fetches the coarsest levels first, then
   * the ones wanted, most needed first.
   */
  update(camera, heightPx) {
    const frustum = new THREE.Frustum().setFromProjectionMatrix(
      new THREE.Matrix4().multiplyMatrices(camera.projectionMatrix, camera.matrixWorldInverse));
    const eye = camera.getWorldPosition(new THREE.Vector3());
    const scale = heightPx / (2 * Math.tan(THREE.MathUtils.degToRad(camera.fov) / 2));
    const wanted = [];
    let drawn = 0;
    for (const tile of this.tiles) {
      const { levels } = tile;
      const coarsest = levels.length - 1;
      const distance = Math.max(tile.sphere.center.distanceTo(eye) - tile.sphere.radius, 1e-6);
      const pixels = (l) => (levels[l].error * scale) / distance;
      let target = coarsest;
      if (frustum.intersectsBox(tile.box)) while (target > 0 && pixels(target) > this.errorPx) target--;
      tile.shown = loadedLevel(levels, target);
      levels.forEach((level, l) => {
        if (level.object) level.object.visible = l === tile.shown;
      });
      if (tile.shown >= 0) drawn += levels[tile.shown].triangles;
      // Without any level a tile gets its coarsest first; then the one it wants.
      const next = levels[coarsest].state !== 'loaded' ? coarsest : target;
      if (levels[next].state === 'idle' && (tile.shown < 0 || tile.shown > target)) {
        const priority = (tile.shown < 0 ? 1e9 : 0) + (tile.shown < 0 ? tile.sphere.radius * scale / distance : pixels(tile.shown));
        wanted.push({ tile, level: next, priority });
      }
      this.freeUnneeded(tile, target);
    }
    this.drawnTriangles = drawn;
    this.wanted = wanted.length;
    wanted.sort((a, b) => b.priority - a.priority);
    for (const w of wanted.slice(0, Math.max(0, MAX_LOADS - this.loading))) this.load(w.tile, w.level);
  }

  /** Frees a tile's levels that are neither shown, wanted nor its coarsest. */
  freeUnneeded(tile, target) {
    const coarsest = tile.levels.length - 1;
    tile.levels.forEach((level, l) => {
      if (!level.object || l === tile.shown || l === target || l === coarsest) return;
      this.group.remove(level.object);
      disposeObject(level.object);
      level.object = null;
      level.state = 'idle';
    });
  }

  async load(tile, l) {
    const level = tile.levels[l];
    level.state = 'loading';
    this.loading++;
    try {
      const buffer = await this.fetchLevel(level.url, this.abort.signal);
      const gltf = await this.loader.parseAsync(buffer, '');
      if (this.abort.signal.aborted) {
        disposeObject(gltf.scene);
        level.state = 'idle';
        return;
      }
      showBytesAsTheyAre(gltf.scene);
      gltf.scene.visible = false;
      gltf.scene.userData.meshLevel = { tile: tile.name, level: l };
      level.object = gltf.scene;
      level.state = 'loaded';
      this.group.add(gltf.scene);
    } catch (err) {
      level.state = err?.name === 'AbortError' ? 'idle' : 'failed';
      if (level.state === 'failed') this.onError(err);
    } finally {
      this.loading--;
      if (!this.abort.signal.aborted) this.onLoad();
    }
  }

  /**
   * Hands the loaded levels over, by blob, to the next version's mesh
   * (which disposes those it does not keep); this one is then empty.
   */
  takeLevels() {
    this.abort.abort();
    const out = new Map();
    for (const tile of this.tiles) {
      for (const level of tile.levels) {
        if (level.object) out.set(level.blob, level.object);
        level.object = null;
      }
    }
    this.group.clear();
    return out;
  }

  /** The drawn levels' meshes (for picking). */
  visibleMeshes() {
    const meshes = [];
    for (const tile of this.tiles) {
      const object = tile.shown >= 0 ? tile.levels[tile.shown].object : null;
      object?.traverse((child) => { if (child.isMesh) meshes.push(child); });
    }
    return meshes;
  }

  dispose() {
    this.abort.abort();
    for (const tile of this.tiles) {
      for (const level of tile.levels) if (level.object) disposeObject(level.object);
    }
    this.group.clear();
  }
}
