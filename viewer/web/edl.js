// Eye-dome lighting (Boucheny's non-photorealistic shading for point
// clouds, as in CloudCompare and Potree): the scene is drawn into a target
// with its depth, then each pixel is darkened by how much nearer than it
// its neighbours are (on a log scale), which outlines edges and shapes
// without normals.

import * as THREE from 'three';

const vertexShader = /* glsl */ `
  varying vec2 vUv;
  void main() {
    vUv = uv;
    gl_Position = vec4(position.xy, 0.0, 1.0);
  }
`;

const fragmentShader = /* glsl */ `
  uniform sampler2D colourTexture;
  uniform sampler2D depthTexture;
  uniform vec2 texel;
  uniform float near;
  uniform float far;
  uniform float strength;
  uniform float radius;
  varying vec2 vUv;

  // The log of the view distance, from the depth buffer's value.
  float logDepth(vec2 at) {
    float d = texture2D(depthTexture, at).x;
    if (d >= 1.0) return -1.0; // nothing drawn there
    float z = near * far / (far - d * (far - near));
    return log2(z);
  }

  void main() {
    vec4 colour = texture2D(colourTexture, vUv);
    float centre = logDepth(vUv);
    if (centre < 0.0) {
      gl_FragColor = colour;
      return;
    }
    float sum = 0.0;
    for (int i = 0; i < 8; i++) {
      float angle = float(i) * 0.78539816;
      vec2 offset = vec2(cos(angle), sin(angle)) * radius * texel;
      float neighbour = logDepth(vUv + offset);
      // Background next to a point counts as far away.
      float delta = neighbour < 0.0 ? 0.0 : max(0.0, centre - neighbour);
      sum += delta;
    }
    float shade = exp(-sum / 8.0 * 300.0 * strength);
    gl_FragColor = vec4(colour.rgb * shade, colour.a);
  }
`;

export class EyeDomeLighting {
  constructor() {
    this.enabled = false;
    this.strength = 0.4;
    this.radius = 1.4; // pixels
    this.target = new THREE.WebGLRenderTarget(1, 1, {
      depthTexture: new THREE.DepthTexture(1, 1, THREE.UnsignedIntType),
    });
    this.material = new THREE.ShaderMaterial({
      uniforms: {
        colourTexture: { value: this.target.texture },
        depthTexture: { value: this.target.depthTexture },
        texel: { value: new THREE.Vector2(1, 1) },
        near: { value: 0.1 },
        far: { value: 1000 },
        strength: { value: this.strength },
        radius: { value: this.radius },
      },
      vertexShader,
      fragmentShader,
      depthTest: false,
      depthWrite: false,
    });
    this.quad = new THREE.Mesh(new THREE.PlaneGeometry(2, 2), this.material);
    this.quadScene = new THREE.Scene();
    this.quadScene.add(this.quad);
    this.quadCamera = new THREE.OrthographicCamera(-1, 1, 1, -1, 0, 1);
  }

  /** The drawing buffer's size in pixels. */
  setSize(width, height) {
    this.target.setSize(width, height);
    this.material.uniforms.texel.value.set(1 / width, 1 / height);
  }

  render(renderer, scene, camera) {
    const u = this.material.uniforms;
    u.near.value = camera.near;
    u.far.value = camera.far;
    u.strength.value = this.strength;
    u.radius.value = this.radius;
    renderer.setRenderTarget(this.target);
    renderer.clear();
    renderer.render(scene, camera);
    renderer.setRenderTarget(null);
    renderer.render(this.quadScene, this.quadCamera);
  }

  dispose() {
    this.target.dispose();
    this.material.dispose();
    this.quad.geometry.dispose();
  }
}
