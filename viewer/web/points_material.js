// The point material: square points of a fixed size in pixels, coloured by
// their RGB or by their height (a blue-cyan-green-yellow-red ramp between
// two heights), in one shader so switching costs nothing. Fused points
// measured by fewer depth maps than minSupport are not drawn (a sparse
// point's support is 0: always drawn).

import * as THREE from 'three';

export const COLOUR_MODES = { rgb: 0, height: 1 };

const vertexShader = /* glsl */ `
  uniform float size;
  uniform int mode;
  uniform vec2 heightRange;
  uniform float minSupport;
  attribute vec3 color;
  attribute float support;
  varying vec3 vColour;

  // Blue, cyan, green, yellow, red at 0, 1/4, 1/2, 3/4, 1.
  vec3 ramp(float t) {
    t = clamp(t, 0.0, 1.0) * 4.0;
    vec3 stops[5] = vec3[5](vec3(0.15, 0.25, 0.85), vec3(0.1, 0.75, 0.9),
                            vec3(0.2, 0.8, 0.25), vec3(0.95, 0.85, 0.15),
                            vec3(0.9, 0.15, 0.1));
    int i = int(min(floor(t), 3.0));
    return mix(stops[i], stops[i + 1], t - float(i));
  }

  void main() {
    if (support > 0.5 && support < minSupport) {
      gl_Position = vec4(0.0, 0.0, 2.0, 1.0); // beyond the far plane: clipped
      gl_PointSize = 0.0;
      vColour = vec3(0.0);
      return;
    }
    vec4 world = modelMatrix * vec4(position, 1.0);
    if (mode == 1) {
      vColour = ramp((world.z - heightRange.x) / max(heightRange.y - heightRange.x, 1e-6));
    } else {
      vColour = color;
    }
    gl_Position = projectionMatrix * viewMatrix * world;
    gl_PointSize = size;
  }
`;

const fragmentShader = /* glsl */ `
  varying vec3 vColour;
  void main() {
    gl_FragColor = vec4(vColour, 1.0);
  }
`;

/**
 * The depth maps a fused point must have been measured by to be shown by
 * default (ColoredPoint's kConfidentSupport: its own and two that agree).
 */
export const CONFIDENT_SUPPORT = 3;

/** Whether a point of `support` is drawn at `minSupport` (as the shader). */
export function shownAt(support, minSupport) {
  return support === 0 || support >= minSupport;
}

/**
 * A ShaderMaterial with .setSize(px), .setMode(name), .setHeightRange(lo, hi)
 * and .setMinSupport(n).
 */
export function createPointsMaterial() {
  const material = new THREE.ShaderMaterial({
    uniforms: {
      size: { value: 2 },
      mode: { value: COLOUR_MODES.rgb },
      heightRange: { value: new THREE.Vector2(0, 1) },
      minSupport: { value: CONFIDENT_SUPPORT },
    },
    vertexShader,
    fragmentShader,
  });
  material.setSize = (px) => { material.uniforms.size.value = px; };
  material.setMode = (name) => { material.uniforms.mode.value = COLOUR_MODES[name] ?? 0; };
  material.setHeightRange = (lo, hi) => { material.uniforms.heightRange.value.set(lo, hi); };
  material.setMinSupport = (n) => { material.uniforms.minSupport.value = n; };
  return material;
}
