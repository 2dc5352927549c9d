// A model's components (separately reconstructed parts of a site, docs/
// engine.md "Components"): one tint each, for the frusta and the legend.
// The largest keeps the frusta's usual orange, so a site in one piece looks
// as it always did.

import { el, formatCount } from './util.js';

// Hues far apart around the wheel, the first the frusta's orange.
const PALETTE = [0xf0a040, 0x40b0f0, 0xa0e060, 0xe060c0, 0xf0e040, 0x60e0c0, 0xb080f0, 0xf06060];

/**
 * The model's components, largest first, each with its tint:
 * [{id, images, points, colour}]. Models written before components hold
 * one, made of all their images.
 */
export function componentsOf(model) {
  let list = Array.isArray(model.components) ? model.components : [];
  if (list.length === 0) {
    list = [{ id: 0, images: (model.images || []).length, points: (model.points ?? 0) }];
  }
  const sorted = [...list].sort((a, b) => (b.images ?? 0) - (a.images ?? 0) || a.id - b.id);
  return sorted.map((c, i) => ({ id: c.id, images: c.images ?? 0, points: c.points ?? 0, colour: PALETTE[i % PALETTE.length] }));
}

/** A map from component id to its tint, for the frusta. */
export function componentColours(model) {
  return new Map(componentsOf(model).map((c) => [c.id, c.colour]));
}

function cssColour(colour) {
  return `#${colour.toString(16).padStart(6, '0')}`;
}

/**
 * Fills the legend: one line per component (its tint, id, photos, points);
 * hidden while the site is in one piece.
 */
export function renderComponentLegend(list, model) {
  const components = componentsOf(model);
  list.hidden = components.length < 2;
  list.replaceChildren(...components.map((c) => el('li', { attrs: { 'data-component': c.id } }, [
    el('span', { className: 'swatch', attrs: { style: `background:${cssColour(c.colour)}`, 'data-colour': cssColour(c.colour) } }),
    el('span', { text: `part ${c.id} · ${formatCount(c.images)} photos · ${formatCount(c.points)} points` }),
  ])));
}
