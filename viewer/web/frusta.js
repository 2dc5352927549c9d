// Camera frusta of a model's registered images, each with its photo's
// thumbnail on the far rectangle.
//
// Poses in the model are world-to-camera, COLMAP style: a world point X maps
// to R X + t in camera coordinates with OpenCV axes (x right, y down, z
// forward), R from the unit quaternion qvec = [w, x, y, z]. The camera sits
// at C = -R^T t and its camera-to-world transform is (R^T, C).

import * as THREE from 'three';
import { limiter } from './util.js';
import { componentColours } from './components.js';

const LINE_COLOR = 0xf0a040;
const HIGHLIGHT_COLOR = 0xffffff;

/** The camera-to-world rotation (R^T) of an image, as a quaternion. */
export function cameraRotation(image) {
  const [w, x, y, z] = image.qvec;
  return new THREE.Quaternion(x, y, z, w).normalize().invert();
}

/** The camera centre in world coordinates: `centre` if given, else -R^T t. */
export function cameraCentre(image) {
  if (Array.isArray(image.centre) && image.centre.length === 3) {
    return new THREE.Vector3(...image.centre);
  }
  return new THREE.Vector3(...image.tvec).applyQuaternion(cameraRotation(image)).negate();
}

/** The camera-to-world matrix of an image. */
export function cameraToWorld(image) {
  return new THREE.Matrix4().compose(cameraCentre(image), cameraRotation(image), new THREE.Vector3(1, 1, 1));
}

/** The image's intrinsics: `camera` is an index into cameras or a camera id. */
export function intrinsicsOf(model, image) {
  const cameras = model.cameras || [];
  if (typeof image.camera === 'number') return cameras[image.camera] || null;
  return cameras.find((c) => c.id === image.camera) || null;
}

/**
 * The far rectangle's corners in camera coordinates, at `depth` along the
 * optical axis, for the image's corner pixels in the order top-left,
 * top-right, bottom-right, bottom-left, with the matching texture
 * coordinates (u right, v down: textures are uploaded without a flip).
 */
function farCorners(camera, depth) {
  const pixels = [
    [0, 0],
    [camera.width, 0],
    [camera.width, camera.height],
    [0, camera.height],
  ];
  return pixels.map(([px, py]) => ({
    point: new THREE.Vector3(((px - camera.cx) / camera.fx) * depth, ((py - camera.cy) / camera.fy) * depth, depth),
    uv: [px / camera.width, py / camera.height],
  }));
}

function outlineGeometry(corners) {
  const apex = [0, 0, 0];
  const positions = [];
  for (let i = 0; i < 4; i++) {
    const a = corners[i].point;
    const b = corners[(i + 1) % 4].point;
    positions.push(...apex, a.x, a.y, a.z); // apex to corner
    positions.push(a.x, a.y, a.z, b.x, b.y, b.z); // rectangle edge
  }
  // A small tick above the top edge marks the image's up side.
  const [tl, tr] = [corners[0].point, corners[1].point];
  const mid = tl.clone().add(tr).multiplyScalar(0.5);
  const lift = tl.distanceTo(tr) * 0.12;
  positions.push(tl.x * 0.8 + tr.x * 0.2, tl.y, tl.z, mid.x, mid.y - lift, mid.z);
  positions.push(mid.x, mid.y - lift, mid.z, tl.x * 0.2 + tr.x * 0.8, tr.y, tr.z);
  const geometry = new THREE.BufferGeometry();
  geometry.setAttribute('position', new THREE.Float32BufferAttribute(positions, 3));
  return geometry;
}

function imageGeometry(corners) {
  const geometry = new THREE.BufferGeometry();
  geometry.setAttribute('position', new THREE.Float32BufferAttribute(corners.flatMap((c) => c.point.toArray()), 3));
  geometry.setAttribute('uv', new THREE.Float32BufferAttribute(corners.flatMap((c) => c.uv), 2));
  geometry.setIndex([0, 1, 2, 0, 2, 3]);
  return geometry;
}

/**
 * Thumbnails as textures, fetched once per capture with the bearer token
 * (GET /v1/captures/{id}/thumbnail.jpg?size=256). A failed fetch yields null
 * and is not retried until the cache is disposed.
 */
export class ThumbnailCache {
  constructor(api, size = 256) {
    this.api = api;
    this.size = size;
    this.textures = new Map();
    this.limit = limiter(4);
    this.disposed = false;
  }

  get(captureId) {
    let entry = this.textures.get(captureId);
    if (!entry) {
      entry = this.limit(() => this.load(captureId)).catch(() => null);
      this.textures.set(captureId, entry);
    }
    return entry;
  }

  async load(captureId) {
    if (this.disposed) return null;
    const url = `/v1/captures/${encodeURIComponent(captureId)}/thumbnail.jpg?size=${this.size}`;
    const blob = await this.api.blob(url);
    const bitmap = await createImageBitmap(blob);
    if (this.disposed) {
      bitmap.close();
      return null;
    }
    const texture = new THREE.Texture(bitmap);
    texture.flipY = false;
    texture.generateMipmaps = false;
    texture.minFilter = THREE.LinearFilter;
    texture.needsUpdate = true;
    return texture;
  }

  dispose() {
    this.disposed = true;
    for (const entry of this.textures.values()) {
      entry.then((texture) => {
        if (!texture) return;
        texture.image?.close?.();
        texture.dispose();
      });
    }
    this.textures.clear();
  }
}

/** All frusta of one model, as one group in the scene. */
export class FrustumSet {
  /** @param {() => void} onChange called when something visible changed */
  constructor(onChange) {
    this.group = new THREE.Group();
    this.group.name = 'frusta';
    this.onChange = onChange;
    this.lineMaterials = new Map(); // tint -> material, one per component's tint
    this.highlightMaterial = new THREE.LineBasicMaterial({ color: HIGHLIGHT_COLOR });
    this.placeholder = new THREE.MeshBasicMaterial({
      color: 0x808080, transparent: true, opacity: 0.25, side: THREE.DoubleSide, depthWrite: false,
    });
    this.entries = new Map();
    this.highlighted = null;
    this.generation = 0;
  }

  /**
   * Rebuilds the frusta of a model's images.
   * @param {object} model the model document's attrs
   * @param {number} depth the far rectangle's distance from the apex
   * @param {ThumbnailCache|null} thumbnails
   */
  update(model, depth, thumbnails) {
    this.clear();
    const generation = ++this.generation;
    const colours = componentColours(model);
    for (const image of model.images || []) {
      const camera = intrinsicsOf(model, image);
      if (!camera || !Array.isArray(image.qvec) || !Array.isArray(image.tvec)) continue;
      const corners = farCorners(camera, depth);
      const frustum = new THREE.Group();
      frustum.name = image.id;
      frustum.matrixAutoUpdate = false;
      frustum.matrix.copy(cameraToWorld(image));
      // Tinted by its component (models before components: one tint).
      const tint = this.lineMaterial(colours.get(image.component ?? 0) ?? LINE_COLOR);
      const outline = new THREE.LineSegments(outlineGeometry(corners),
        image.id === this.highlighted ? this.highlightMaterial : tint);
      frustum.userData.component = image.component ?? 0;
      const picture = new THREE.Mesh(imageGeometry(corners), this.placeholder);
      frustum.add(outline, picture);
      this.group.add(frustum);
      this.entries.set(image.id, { frustum, outline, picture, tint });

      thumbnails?.get(image.id).then((texture) => {
        if (!texture || generation !== this.generation) return;
        picture.material = new THREE.MeshBasicMaterial({ map: texture, side: THREE.DoubleSide });
        this.onChange();
      });
    }
    this.onChange();
  }

  /** The outline material of one tint (kept for the set's lifetime). */
  lineMaterial(colour) {
    let material = this.lineMaterials.get(colour);
    if (!material) {
      material = new THREE.LineBasicMaterial({ color: colour });
      this.lineMaterials.set(colour, material);
    }
    return material;
  }

  setVisible(visible) {
    this.group.visible = visible;
    this.onChange();
  }

  /** Draws one capture's frustum in the highlight colour (null: none). */
  highlight(captureId) {
    this.highlighted = captureId;
    for (const [id, entry] of this.entries) {
      entry.outline.material = id === captureId ? this.highlightMaterial : entry.tint;
    }
    this.onChange();
  }

  clear() {
    this.generation++;
    for (const { frustum, outline, picture } of this.entries.values()) {
      outline.geometry.dispose();
      picture.geometry.dispose();
      if (picture.material !== this.placeholder) picture.material.dispose();
      this.group.remove(frustum);
    }
    this.entries.clear();
    this.onChange();
  }
}
