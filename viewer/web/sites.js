// The site list and the open site's capture statuses, as table rows.
// Server data goes into the DOM as text only.

import { CaptureStatus } from './capture_status.js';
import { el, formatLatLon, formatTime } from './util.js';

/** A site's id from its document path "/sites/ID". */
export function siteId(doc) {
  return doc.path.replace(/^\/sites\//, '');
}

/**
 * The site that holds `id`'s captures and model now: `id` itself, or the
 * site it grew into (attrs.merged_into, followed through later merges).
 */
export function siteHolding(sites, id) {
  let at = id;
  for (let hops = 0; hops < 64; hops++) {
    const next = sites.find((doc) => siteId(doc) === at)?.attrs?.merged_into;
    if (!next || next === at) return at;
    at = next;
  }
  return at;
}

/** The sites that hold captures: those merged into another are left out. */
export function liveSites(sites) {
  return sites.filter((doc) => !doc.attrs?.merged_into);
}

/** A capture's id from its document path "/captures/ID". */
export function captureId(doc) {
  return doc.path.replace(/^\/captures\//, '');
}

function siteRow(doc, selected) {
  const id = siteId(doc);
  const attrs = doc.attrs || {};
  const version = attrs.model_version || 0;
  const row = el('tr', { attrs: { 'data-site': id, tabindex: 0, title: `site ${id} (${attrs.state || 'waiting'})` } }, [
    el('td', { className: 'site-name', text: attrs.name || id }),
    el('td', { className: 'site-centre', text: formatLatLon(attrs.gps) }),
    el('td', { className: 'site-captures num', text: attrs.capture_count ?? 0 }),
    el('td', { className: 'site-registered num', text: attrs.registered ?? 0 }),
    el('td', { className: 'site-version num', text: version > 0 ? `v${version}` : '-', attrs: { 'data-version': version } }),
    el('td', { className: 'site-updated', text: formatTime(doc.updated), attrs: { title: doc.updated || '' } }),
  ]);
  if (selected) row.classList.add('selected');
  return row;
}

/**
 * Fills the sites table.
 * @param {HTMLElement} tbody
 * @param {object[]} sites the /sites/* documents
 * @param {string|null} current the open site's id
 * @param {(id: string) => void} onOpen
 */
export function renderSites(tbody, sites, current, onOpen) {
  const sorted = [...sites].sort((a, b) =>
    String(a.attrs?.name || a.path).localeCompare(String(b.attrs?.name || b.path)));
  tbody.replaceChildren(...sorted.map((doc) => siteRow(doc, siteId(doc) === current)));
  for (const row of tbody.rows) {
    const open = () => onOpen(row.dataset.site);
    row.addEventListener('click', open);
    row.addEventListener('keydown', (event) => {
      if (event.key === 'Enter') open();
    });
  }
}

/** Marks the open site's row. */
export function markSelectedSite(tbody, current) {
  for (const row of tbody.rows) row.classList.toggle('selected', row.dataset.site === current);
}

/**
 * The captures of one site with their status: the capture documents that
 * name the site, plus those the site or its model lists (a capture the
 * engine has not looked at yet names no site).
 * @returns {{id, filename, scout, status, reason, received}[]}
 */
export function captureStatuses(id, site, model, captureDocs) {
  const byId = new Map(captureDocs.map((doc) => [captureId(doc), doc]));
  const ids = new Set();
  for (const doc of captureDocs) if (doc.attrs?.site === id) ids.add(captureId(doc));
  for (const capture of site?.attrs?.captures || []) ids.add(capture);
  const inModel = model?.attrs?.captures || {};
  for (const capture of Object.keys(inModel)) ids.add(capture);

  const rows = [...ids].map((capture) => {
    const attrs = byId.get(capture)?.attrs || {};
    const status = attrs.status || inModel[capture] || 'unknown';
    // A stored capture the model lists as pending was tried but is not
    // registered yet (the engine tries again as the model grows).
    const waiting = status === CaptureStatus.STORED && inModel[capture] === CaptureStatus.PENDING;
    return {
      id: capture,
      filename: attrs.filename || '',
      scout: attrs.scout || '',
      status,
      reason: attrs.status_reason || (waiting ? 'not registered yet' : ''),
      received: attrs.received || '',
    };
  });
  rows.sort((a, b) => (a.filename || a.id).localeCompare(b.filename || b.id) || a.id.localeCompare(b.id));
  return rows;
}

/**
 * Fills the captures table.
 * @param {HTMLElement} tbody
 * @param {ReturnType<typeof captureStatuses>} rows
 * @param {object} handlers
 * @param {(id: string) => void} handlers.onSelect
 * @param {(id: string) => void} handlers.onOverlay
 */
export function renderCaptures(tbody, rows, { onSelect, onOverlay, onViewFrom }) {
  tbody.replaceChildren(...rows.map((capture) => {
    const state = el('span', { className: `capture-state state-${capture.status}`, text: capture.status });
    const statusCell = el('td', {}, [state]);
    if (capture.reason) statusCell.append(el('div', { className: 'capture-reason', text: capture.reason }));
    const actions = el('td', { className: 'actions' });
    if (capture.status === CaptureStatus.REGISTERED) {
      const button = el('button', { text: 'overlay', attrs: { type: 'button', title: 'the model drawn over the photo' } });
      button.addEventListener('click', (event) => {
        event.stopPropagation();
        onOverlay(capture.id);
      });
      actions.append(button);
      const view = el('button', { text: 'view from', attrs: { type: 'button', title: 'view the model from this photo', 'data-action': 'view-from' } });
      view.addEventListener('click', (event) => {
        event.stopPropagation();
        onViewFrom(capture.id);
      });
      actions.append(view);
    }
    const row = el('tr', {
      className: 'capture-status',
      attrs: { 'data-capture': capture.id, 'data-status': capture.status, title: capture.received ? `received ${formatTime(capture.received)}` : '' },
    }, [
      el('td', { className: 'capture-name', text: capture.filename || capture.id, attrs: { title: capture.id } }),
      el('td', { className: 'capture-scout', text: capture.scout }),
      statusCell,
      actions,
    ]);
    row.addEventListener('click', () => onSelect(capture.id));
    return row;
  }));
}
